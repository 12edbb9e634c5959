// HapticfxOscClient.cs - the UDP connection to `hapticfx serve`; one per scene (put it on any GameObject).
// Sending never blocks the frame: UdpClient.Send on a connected UDP socket returns once the datagram is queued.

using System.Net.Sockets;
using UnityEngine;

namespace Hapticfx
{
    /// <summary>Sends OSC datagrams to `hapticfx serve` (events.osc in the scene: 127.0.0.1:9000 by default).</summary>
    [AddComponentMenu("hapticfx/Hapticfx OSC Client")]
    [DisallowMultipleComponent]
    public class HapticfxOscClient : MonoBehaviour
    {
        [Tooltip("Where `hapticfx serve` listens (events.osc in the scene)")]
        public string host = "127.0.0.1";
        public int port = 9000;

        UdpClient udp;

        void Awake()
        {
            Connect();
        }

        void OnDestroy()
        {
            if (udp != null) udp.Close();
            udp = null;
        }

        /// <summary>Opens the socket (Awake does); call again after changing host or port.</summary>
        public void Connect()
        {
            if (udp != null) udp.Close();
            udp = new UdpClient();
            udp.Connect(host, port);
        }

        /// <summary>Sends one datagram built by HapticfxOsc; a network error is logged, never thrown.</summary>
        public void Send(byte[] datagram)
        {
            if (udp == null) Connect();
            try { udp.Send(datagram, datagram.Length); }
            catch (SocketException e) { Debug.LogWarning("hapticfx: " + e.Message); }
        }
    }
}
