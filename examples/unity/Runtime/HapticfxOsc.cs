// HapticfxOsc.cs - the bytes of the hapticfx OSC protocol (docs/protocol.md, version 2), built by hand.
// Plain .NET (no UnityEngine types), so the same code runs in a console program and in the editor.

using System;
using System.IO;
using System.Text;

namespace Hapticfx
{
    /// <summary>Builds /hapticfx/impact messages: OSC 1.0, big-endian, strings padded to 4 bytes.</summary>
    public static class HapticfxOsc
    {
        public const string ImpactAddress = "/hapticfx/impact";

        /// <summary>/hapticfx/impact ,sfid object velocity channel time (version 1: no contact point).</summary>
        public static byte[] BuildImpact(string objectId, float velocity, int channel, double time)
        {
            var buf = new MemoryStream(64);
            WriteString(buf, ImpactAddress);
            WriteString(buf, ",sfid");
            WriteString(buf, objectId);
            WriteFloat(buf, velocity);
            WriteInt(buf, channel);
            WriteDouble(buf, time);
            return buf.ToArray();
        }

        /// <summary>/hapticfx/impact ,sfidffffff object velocity channel time point normal. The point (m) and the
        /// normal are in the head frame: x right, y forward, z up, from the head's centre (see HeadFrame).</summary>
        public static byte[] BuildImpact(string objectId, float velocity, int channel, double time,
                                         float px, float py, float pz, float nx, float ny, float nz)
        {
            var buf = new MemoryStream(96);
            WriteString(buf, ImpactAddress);
            WriteString(buf, ",sfidffffff");
            WriteString(buf, objectId);
            WriteFloat(buf, velocity);
            WriteInt(buf, channel);
            WriteDouble(buf, time);
            foreach (float v in new[] { px, py, pz, nx, ny, nz })
                WriteFloat(buf, v);
            return buf.ToArray();
        }

        // An OSC string: UTF-8 bytes, a NUL, then NULs up to a multiple of 4 bytes.
        static void WriteString(Stream s, string text)
        {
            byte[] b = Encoding.UTF8.GetBytes(text);
            s.Write(b, 0, b.Length);
            int pad = 4 - (b.Length % 4);
            for (int i = 0; i < pad; i++) s.WriteByte(0);
        }

        static void WriteFloat(Stream s, float v) { WriteBigEndian(s, BitConverter.GetBytes(v)); }
        static void WriteInt(Stream s, int v) { WriteBigEndian(s, BitConverter.GetBytes(v)); }
        static void WriteDouble(Stream s, double v) { WriteBigEndian(s, BitConverter.GetBytes(v)); }

        static void WriteBigEndian(Stream s, byte[] b)
        {
            if (BitConverter.IsLittleEndian) Array.Reverse(b);
            s.Write(b, 0, b.Length);
        }
    }
}
