// HapticfxOscClient.cs - send falling-object impacts from Unity to `hapticfx serve`.
//
// No dependencies: builds OSC 1.0 messages by hand and sends them over UDP.
// Attach to the object that represents the user's head (it needs a Collider);
// give each falling object a HapticfxObject component with its hapticfx object id
// (a key of the scene's `effects`, for example "concrete-brick").
// Protocol: docs/protocol.md. Sending never blocks the frame: UdpClient.Send on a
// connected UDP socket returns as soon as the datagram is queued.

using System;
using System.Net.Sockets;
using System.Text;
using UnityEngine;

public class HapticfxOscClient : MonoBehaviour
{
    [Tooltip("Where `hapticfx serve` listens (events.osc in the scene)")]
    public string host = "127.0.0.1";
    public int port = 9000;
    [Tooltip("Actuator channel; -1 uses the channel the scene gives the object")]
    public int channel = -1;
    [Tooltip("Ignore contacts slower than this (m/s): resting objects touch every frame")]
    public float minVelocity = 0.3f;

    UdpClient udp;

    void Awake()
    {
        udp = new UdpClient();
        udp.Connect(host, port);
    }

    void OnDestroy()
    {
        udp?.Close();
    }

    void OnCollisionEnter(Collision collision)
    {
        var tag = collision.collider.GetComponentInParent<HapticfxObject>();
        if (tag == null) return;
        // Normal component of the relative velocity at the contact: the impact velocity.
        float v = Mathf.Abs(Vector3.Dot(collision.relativeVelocity, collision.GetContact(0).normal));
        if (v < minVelocity) return;
        SendImpact(tag.objectId, v, channel, Time.timeAsDouble);
    }

    /// <summary>Send /hapticfx/impact ,sfid object velocity channel time.</summary>
    public void SendImpact(string objectId, float velocity, int ch, double simTime)
    {
        byte[] msg = BuildImpact(objectId, velocity, ch, simTime);
        try { udp.Send(msg, msg.Length); }
        catch (SocketException e) { Debug.LogWarning("hapticfx: " + e.Message); }
    }

    public static byte[] BuildImpact(string objectId, float velocity, int ch, double simTime)
    {
        var buf = new System.IO.MemoryStream(64);
        WriteString(buf, "/hapticfx/impact");
        WriteString(buf, ",sfid");
        WriteString(buf, objectId);
        WriteBigEndian(buf, BitConverter.GetBytes(velocity));
        WriteBigEndian(buf, BitConverter.GetBytes(ch));
        WriteBigEndian(buf, BitConverter.GetBytes(simTime));
        return buf.ToArray();
    }

    // OSC string: UTF-8 bytes, a NUL, then NULs up to a multiple of 4 bytes.
    static void WriteString(System.IO.Stream s, string text)
    {
        byte[] b = Encoding.UTF8.GetBytes(text);
        s.Write(b, 0, b.Length);
        int pad = 4 - (b.Length % 4);
        for (int i = 0; i < pad; i++) s.WriteByte(0);
    }

    static void WriteBigEndian(System.IO.Stream s, byte[] b)
    {
        if (BitConverter.IsLittleEndian) Array.Reverse(b);
        s.Write(b, 0, b.Length);
    }
}

/// <summary>Marks a falling object with its hapticfx object id.</summary>
public class HapticfxObject : MonoBehaviour
{
    public string objectId = "concrete-brick";
}
