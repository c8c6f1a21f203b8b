// Moves the rope's head from C# through the C library (P/Invoke), as a Unity script would.
// Build and run: mcs -out:move.exe Move.cs && LD_LIBRARY_PATH=target/release mono move.exe PREFIX
// Prints the joints' bits after a query, for the test to compare with a Rust client. With `loop N` it
// moves the head around a small circle N times back to back instead and prints the round trip's
// percentiles (the motion of `latency client`).
using System;
using System.Runtime.InteropServices;

[StructLayout(LayoutKind.Sequential)]
public struct Vec3
{
    public double X, Y, Z;
    public Vec3(double x, double y, double z) { X = x; Y = y; Z = z; }
}

public sealed class TractrixException : Exception
{
    public readonly int Code;
    public TractrixException(int code, string message) : base(message) { Code = code; }
}

// The C library's functions (tractrix_client.h).
static class Native
{
    const string Lib = "tractrix_client";
    public const uint JointHead = 0xFFFFFFFF;
    public const int WaitHybrid = 2;
    public const int ErrBuffer = -7;
    [DllImport(Lib)] public static extern int tractrix_client_open(string prefix, int wait, double connectTimeout, double callTimeout, out IntPtr client);
    [DllImport(Lib)] public static extern IntPtr tractrix_last_open_error();
    [DllImport(Lib)] public static extern void tractrix_client_close(IntPtr client);
    [DllImport(Lib)] public static extern IntPtr tractrix_client_error(IntPtr client);
    [DllImport(Lib)] public static extern int tractrix_client_find_chain(IntPtr client, string name, out uint chain);
    [DllImport(Lib)] public static extern int tractrix_client_move(IntPtr client, uint chain, uint joint, Vec3 target, [Out] Vec3[] joints, UIntPtr capacity, out UIntPtr n);
    [DllImport(Lib)] public static extern int tractrix_client_query(IntPtr client, uint chain, [Out] Vec3[] joints, UIntPtr capacity, out UIntPtr n);
}

// What a Unity author writes once: a disposable client, exceptions with the service's reason.
public sealed class TractrixClient : IDisposable
{
    IntPtr handle;

    public TractrixClient(string prefix)
    {
        int rc = Native.tractrix_client_open(prefix, Native.WaitHybrid, 5.0, 5.0, out handle);
        if (rc != 0) throw new TractrixException(rc, Marshal.PtrToStringAnsi(Native.tractrix_last_open_error()));
    }

    void Check(int rc)
    {
        if (rc != 0) throw new TractrixException(rc, Marshal.PtrToStringAnsi(Native.tractrix_client_error(handle)));
    }

    public uint Chain(string name)
    {
        uint id;
        Check(Native.tractrix_client_find_chain(handle, name, out id));
        return id;
    }

    // Moves a joint; the new joints are written into `joints`; returns their count.
    public int Move(uint chain, uint joint, Vec3 target, Vec3[] joints)
    {
        UIntPtr n;
        Check(Native.tractrix_client_move(handle, chain, joint, target, joints, (UIntPtr)joints.Length, out n));
        return (int)n;
    }

    public Vec3[] Query(uint chain)
    {
        var joints = new Vec3[64];
        UIntPtr n;
        int rc = Native.tractrix_client_query(handle, chain, joints, (UIntPtr)joints.Length, out n);
        if (rc == Native.ErrBuffer)
        {
            joints = new Vec3[(int)n];
            rc = Native.tractrix_client_query(handle, chain, joints, (UIntPtr)joints.Length, out n);
        }
        Check(rc);
        Array.Resize(ref joints, (int)n);
        return joints;
    }

    public void Dispose()
    {
        if (handle != IntPtr.Zero) Native.tractrix_client_close(handle);
        handle = IntPtr.Zero;
    }
}

static class Program
{
    static string Bits(double x) { return BitConverter.DoubleToInt64Bits(x).ToString("x16"); }

    static int Loop(TractrixClient client, uint rope, int n)
    {
        var joints = client.Query(rope);
        Vec3 head = joints[joints.Length - 1];
        int warmup = n / 10;
        var us = new double[n];
        var clock = new System.Diagnostics.Stopwatch();
        for (int i = 0; i < warmup + n; i++)
        {
            double a = 2.0 * Math.PI * (i % 200) / 200.0;
            var target = new Vec3(head.X + 0.5 * (Math.Cos(a) - 1.0), head.Y + 0.5 * Math.Sin(a), head.Z);
            clock.Restart();
            client.Move(rope, Native.JointHead, target, joints);
            clock.Stop();
            if (i >= warmup) us[i - warmup] = clock.Elapsed.TotalMilliseconds * 1000.0;
        }
        Array.Sort(us);
        Func<double, double> pct = p => us[(int)(p * (n - 1))];
        Console.WriteLine("{0} moves at 0 Hz: round trip p50 {1:F1} us, p99 {2:F1} us, max {3:F1} us", n, pct(0.5), pct(0.99), us[n - 1]);
        return 0;
    }

    static int Main(string[] args)
    {
        try
        {
            using (var client = new TractrixClient(args.Length > 0 ? args[0] : null))
            {
                uint rope = client.Chain("rope");
                if (args.Length > 2 && args[1] == "loop") return Loop(client, rope, int.Parse(args[2]));
                var joints = new Vec3[64];
                int n = client.Move(rope, Native.JointHead, new Vec3(37.0, 6.0, 0.5), joints);
                Console.WriteLine("moved: {0} joints, head {1:F6} {2:F6} {3:F6}", n, joints[n - 1].X, joints[n - 1].Y, joints[n - 1].Z);
                try { client.Move(rope, Native.JointHead, new Vec3(double.NaN, 0, 0), joints); }
                catch (TractrixException e) { Console.WriteLine("refused: {0} {1}", e.Code, e.Message); }
                var q = client.Query(rope);
                for (int i = 0; i < q.Length; i++)
                    Console.WriteLine("joint {0} {1} {2} {3}", i, Bits(q[i].X), Bits(q[i].Y), Bits(q[i].Z));
            }
        }
        catch (TractrixException e)
        {
            Console.Error.WriteLine("tractrix error {0}: {1}", e.Code, e.Message);
            return 1;
        }
        return 0;
    }
}
