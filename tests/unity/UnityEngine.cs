// A stand-in for the few UnityEngine types examples/unity/Runtime uses, written for tests/test_unity_package.py:
// just enough to compile the package with Mono's mcs and to drive its component from a console program.
// Not Unity: no physics, no scene; the shapes of the API (names, signatures, semantics used) follow Unity 2019.4.
using System;

namespace UnityEngine
{
    public struct Vector3
    {
        public float x, y, z;
        public Vector3(float x, float y, float z) { this.x = x; this.y = y; this.z = z; }
        public static float Dot(Vector3 a, Vector3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
        public float magnitude { get { return (float)Math.Sqrt(Dot(this, this)); } }
        public Vector3 normalized { get { float m = magnitude; return m > 1e-5f ? this / m : new Vector3(0, 0, 0); } }
        public static Vector3 operator -(Vector3 a, Vector3 b) { return new Vector3(a.x - b.x, a.y - b.y, a.z - b.z); }
        public static Vector3 operator +(Vector3 a, Vector3 b) { return new Vector3(a.x + b.x, a.y + b.y, a.z + b.z); }
        public static Vector3 operator -(Vector3 a) { return new Vector3(-a.x, -a.y, -a.z); }
        public static Vector3 operator /(Vector3 a, float d) { return new Vector3(a.x / d, a.y / d, a.z / d); }
    }

    public static class Mathf { public static float Abs(float f) { return Math.Abs(f); } }

    public static class Time
    {
        public static float fixedTime;  // set by the test program
        public static double fixedTimeAsDouble { get { return fixedTime; } }  // Unity 2020.2 and later
    }

    public static class Debug { public static void LogWarning(object message) { Console.Error.WriteLine(message); } }

    public class Object
    {
        static readonly System.Collections.Generic.List<Object> all = new System.Collections.Generic.List<Object>();
        public Object() { all.Add(this); }
        public static T FindObjectOfType<T>() where T : Object
        {
            foreach (var o in all) if (o is T) return (T)o;
            return null;
        }
    }

    public class Component : Object { public Transform transform; }
    public class Behaviour : Component { }
    public class MonoBehaviour : Behaviour { }
    public class Collider : Component { }
    public class Rigidbody : Component { }

    /// <summary>A transform with a rotation about the vertical axis only (yaw, degrees), enough for the test.</summary>
    public class Transform : Component
    {
        public Vector3 position;
        public float yawDegrees;
        public Transform parent;
        public bool IsChildOf(Transform t) { for (var p = this; p != null; p = p.parent) if (p == t) return true; return false; }
        public Vector3 InverseTransformDirection(Vector3 v)
        {
            // Unity's yaw R_y(t) takes forward (0, 0, 1) to (sin t, 0, cos t); its inverse is R_y(-t)
            double a = -yawDegrees * Math.PI / 180.0;
            float c = (float)Math.Cos(a), s = (float)Math.Sin(a);
            return new Vector3(c * v.x + s * v.z, v.y, -s * v.x + c * v.z);
        }
    }

    public struct ContactPoint
    {
        public Vector3 point;
        public Vector3 normal;
        public ContactPoint(Vector3 point, Vector3 normal) { this.point = point; this.normal = normal; }
    }

    public class Collision
    {
        public Vector3 relativeVelocity;
        public Transform transform;
        ContactPoint[] contacts;
        public Collision(Transform other, Vector3 relativeVelocity, params ContactPoint[] contacts)
        {
            transform = other; this.relativeVelocity = relativeVelocity; this.contacts = contacts;
        }
        public int contactCount { get { return contacts.Length; } }
        public ContactPoint GetContact(int index) { return contacts[index]; }
    }

    [AttributeUsage(AttributeTargets.Field)]
    public class TooltipAttribute : Attribute { public TooltipAttribute(string tooltip) { } }
    [AttributeUsage(AttributeTargets.Class)]
    public class AddComponentMenu : Attribute { public AddComponentMenu(string menuName) { } }
    [AttributeUsage(AttributeTargets.Class)]
    public class DisallowMultipleComponent : Attribute { }
    [AttributeUsage(AttributeTargets.Class, AllowMultiple = true)]
    public class RequireComponent : Attribute { public RequireComponent(Type type) { } }
}
