// HapticfxObject.cs - put on a falling object (with a Rigidbody and a Collider): each time it hits the head,
// it sends the impact to `hapticfx serve` through the scene's HapticfxOscClient.

using UnityEngine;

namespace Hapticfx
{
    /// <summary>Marks a falling object with its hapticfx object id and sends its head impacts.</summary>
    [AddComponentMenu("hapticfx/Hapticfx Object")]
    [RequireComponent(typeof(Rigidbody))]
    public class HapticfxObject : MonoBehaviour
    {
        [Tooltip("A key of the scene's `effects`, for example concrete-brick")]
        public string objectId = "concrete-brick";
        [Tooltip("The head: its Transform (with the Collider on it or on a child); its axes are the head's")]
        public Transform head;
        [Tooltip("The client that sends; found in the scene when left empty")]
        public HapticfxOscClient client;
        [Tooltip("Ignore contacts slower than this (m/s): resting objects touch every frame")]
        public float minVelocity = 0.3f;
        [Tooltip("-1: the channel the scene wires the object to")]
        public int channel = -1;

        void Awake()
        {
            if (client == null) client = FindObjectOfType<HapticfxOscClient>();
        }

        void OnCollisionEnter(Collision collision)
        {
            if (head == null || client == null) return;
            if (collision.transform != head && !collision.transform.IsChildOf(head)) return;
            ContactPoint contact = collision.GetContact(0);
            Vector3 normal = contact.normal;
            Vector3 fromCentre = contact.point - head.position;
            if (Vector3.Dot(normal, fromCentre) < 0) normal = -normal;  // the head frame's normal points outwards
            // Unity's relativeVelocity is taken before the solver resolves the contact: the closing speed.
            float speed = Mathf.Abs(Vector3.Dot(collision.relativeVelocity, normal));
            if (speed < minVelocity) return;
            // Unity's axes (x right, y up, z forward; left-handed) in the head's space -> the head frame (x right,
            // y forward, z up); InverseTransformDirection keeps metres whatever the head's scale.
            Vector3 p = head.InverseTransformDirection(fromCentre);
            Vector3 n = head.InverseTransformDirection(normal).normalized;
            client.Send(HapticfxOsc.BuildImpact(objectId, speed, channel, Now(), p.x, p.z, p.y, n.x, n.z, n.y));
        }

        static double Now()
        {
#if UNITY_2020_2_OR_NEWER
            return Time.fixedTimeAsDouble;
#else
            return Time.fixedTime;  // Unity 2019.4: a float, milliseconds lost after about 4.5 hours
#endif
        }
    }
}
