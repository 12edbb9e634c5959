// A console program for tests/test_unity_package.py: sends what the Unity package would send to a running
// `hapticfx serve` (port in argv[0]): two messages from its encoder, then one from HapticfxObject's collision
// handler, called as Unity calls it (by name, through reflection) with a stand-in Collision.
using System;
using System.Reflection;
using System.Threading;
using Hapticfx;
using UnityEngine;

static class SendImpacts
{
    static int Main(string[] args)
    {
        var client = new HapticfxOscClient { host = "127.0.0.1", port = int.Parse(args[0]) };
        client.Connect();
        client.Send(HapticfxOsc.BuildImpact("concrete-brick", 3.8f, -1, 1.25));
        Thread.Sleep(20);
        client.Send(HapticfxOsc.BuildImpact("steel-plate", 4.2f, 0, 2.5, 0.01f, 0.02f, 0.13f, 0f, 0f, 1f));
        Thread.Sleep(20);

        // The head at (0, 1.62, 0) turned 90 degrees (facing +x); a wood beam lands on its front-top at
        // 3.5 m/s straight down, plus 1 m/s sideways (across the normal: it must not count).
        var head = new UnityEngine.Transform { position = new Vector3(0f, 1.62f, 0f), yawDegrees = 90f };
        var beam = new HapticfxObject { objectId = "wood-beam", head = head };
        typeof(HapticfxObject).GetMethod("Awake", BindingFlags.Instance | BindingFlags.NonPublic).Invoke(beam, null);
        var normal = new Vector3(0.6f, 0.8f, 0f);                    // out of the head, towards +x (its front) and up
        var point = head.position + new Vector3(0.078f, 0.104f, 0f);  // 0.13 m from the centre along the normal
        UnityEngine.Time.fixedTime = 3.75f;
        var hit = new Collision(head, new Vector3(0f, -3.5f, 1f), new ContactPoint(point, -normal));  // either sign
        typeof(HapticfxObject).GetMethod("OnCollisionEnter", BindingFlags.Instance | BindingFlags.NonPublic)
            .Invoke(beam, new object[] { hit });
        Console.WriteLine("sent 3");
        return 0;
    }
}
