// The smallest C# program (P/Invoke on the C library): move the rope's head, print where it is.
using System;
using System.Runtime.InteropServices;

[StructLayout(LayoutKind.Sequential)] struct Vec3 { public double X, Y, Z; }

static class Hello
{
    [DllImport("tractrix_client")] static extern int tractrix_client_open(string prefix, int wait, double connect, double call, out IntPtr client);
    [DllImport("tractrix_client")] static extern IntPtr tractrix_last_open_error();
    [DllImport("tractrix_client")] static extern IntPtr tractrix_client_error(IntPtr client);
    [DllImport("tractrix_client")] static extern int tractrix_client_find_chain(IntPtr client, string name, out uint chain);
    [DllImport("tractrix_client")] static extern int tractrix_client_move(IntPtr client, uint chain, uint joint, Vec3 target, [Out] Vec3[] joints, UIntPtr capacity, out UIntPtr n);
    [DllImport("tractrix_client")] static extern void tractrix_client_close(IntPtr client);

    static int Main(string[] args)
    {
        IntPtr client;
        if (tractrix_client_open(args.Length > 0 ? args[0] : null, 2, 5.0, 5.0, out client) != 0)
        {
            Console.Error.WriteLine(Marshal.PtrToStringAnsi(tractrix_last_open_error()));
            return 1;
        }
        uint rope;
        var joints = new Vec3[64];
        UIntPtr n;
        var target = new Vec3 { X = 38.0, Y = 5.0, Z = 1.0 };
        if (tractrix_client_find_chain(client, "rope", out rope) != 0 ||
            tractrix_client_move(client, rope, 0xFFFFFFFF, target, joints, (UIntPtr)joints.Length, out n) != 0)
        {
            Console.Error.WriteLine(Marshal.PtrToStringAnsi(tractrix_client_error(client)));
            return 1;
        }
        Vec3 head = joints[(int)n - 1];
        Console.WriteLine("head at {0} {1} {2}, {3} joints", head.X, head.Y, head.Z, n);
        tractrix_client_close(client);
        return 0;
    }
}
