// NativeMethods.cs: the C ABI of src/ardy_c.h (ARDY_ABI_VERSION 4), 1:1.
//
// Every function, struct and enum of the header, in the header's order, with
// the C names. Rules (see bindings/csharp/README.md):
//   - handles are SafeHandles (ModelHandle, PlannerHandle, BatcherHandle) so
//     that a handle is never freed while a call on it is running, and a
//     created handle is owned even if an exception interrupts the caller;
//   - bool (C99 _Bool, one byte) is [MarshalAs(UnmanagedType.U1)], in
//     signatures and in structs;
//   - const char* arguments are UTF-8, marshalled explicitly
//     (UnmanagedType.LPUTF8Str); returned const char* are IntPtr, decoded by
//     Utf8.FromNative (they belong to the library and stay valid only until
//     the next failing call: copy them at once);
//   - size_t is UIntPtr, arrays are typed pointers (the idiomatic layer pins
//     managed arrays and spans with `fixed`: no copy, no managed allocation);
//   - structs are LayoutKind.Sequential, field for field in the header's
//     order; C arrays inside a struct are spelled as separate fields (x, y,
//     z) so that the structs stay blittable.
// This file is internal: the public API is Model, Planner, Batcher.
using System;
using System.Runtime.InteropServices;
using System.Text;

namespace Ardy
{
    /// <summary>ardy_status: what a call of the C ABI returned.</summary>
    public enum Status
    {
        Ok = 0,                   // ARDY_OK
        InvalidArgument = 1,      // ARDY_ERROR_INVALID_ARGUMENT: NULL pointer, NaN/inf, out of range, bad prompt, unknown joint
        IO = 2,                   // ARDY_ERROR_IO: a file or folder is missing or unreadable
        InvalidModel = 3,         // ARDY_ERROR_INVALID_MODEL: the model package is malformed
        NotReady = 4,             // ARDY_ERROR_NOT_READY: no motion has been generated yet
        BufferTooSmall = 5,       // ARDY_ERROR_BUFFER_TOO_SMALL: a caller-provided array is too small
        OutOfMemory = 6,          // ARDY_ERROR_OUT_OF_MEMORY
        Runtime = 7,              // ARDY_ERROR_RUNTIME: inference or another failure inside the runtime
        Timeout = 8,              // ARDY_ERROR_TIMEOUT
    }

    /// <summary>ardy_model_params.</summary>
    [StructLayout(LayoutKind.Sequential)]
    internal struct ardy_model_params
    {
        public int intra_op_threads;
        public uint text_cache_capacity;
        public uint max_prompt_chars;
        [MarshalAs(UnmanagedType.U1)] public bool fast_threads;
    }

    /// <summary>ardy_file_buffer.</summary>
    [StructLayout(LayoutKind.Sequential)]
    internal struct ardy_file_buffer
    {
        public IntPtr name;   // const char* (UTF-8, NUL-terminated)
        public IntPtr data;   // const void*
        public UIntPtr size;  // size_t
    }

    /// <summary>ardy_planner_params.</summary>
    [StructLayout(LayoutKind.Sequential)]
    internal struct ardy_planner_params
    {
        public int steps;
        public float w_text;
        public float w_con;
        public float path_guidance_scale;
        public float text_only_guidance_scale;
        public double history_seconds;
        public double future_seconds;
        public double start_x;
        public double start_z;
        public ulong seed;
        public uint min_buffer_frames;
        public double initial_latency_seconds;
        public double latency_margin;
        public double low_water_seconds;
        public double keep_behind_seconds;
        [MarshalAs(UnmanagedType.U1)] public bool cancel_obsolete_windows;
        public double output_smoothing_frames;
        public int interpolate_root;
        public double max_root_speed;
        [MarshalAs(UnmanagedType.U1)] public bool foot_lock;
        public IntPtr batcher;          // ardy_batcher*
        public IntPtr initial_history;  // const float*
        public uint initial_history_frames;
    }

    /// <summary>ardy_batcher_params.</summary>
    [StructLayout(LayoutKind.Sequential)]
    internal struct ardy_batcher_params
    {
        public double gather_seconds;
        public uint max_windows;
    }

    /// <summary>ardy_batcher_stats.</summary>
    [StructLayout(LayoutKind.Sequential)]
    public struct BatcherStats
    {
        public ulong batches;
        public ulong windows;
        public ulong withdrawn;
        public ulong failed_batches;
        public uint largest_batch;
        public uint queued;
    }

    /// <summary>ardy_pose_info. root_position[3] is spelled root_position_x/y/z (same layout, blittable).</summary>
    [StructLayout(LayoutKind.Sequential)]
    public struct PoseInfo
    {
        public double time;
        public float root_position_x;
        public float root_position_y;
        public float root_position_z;
        public float heading;
        public ulong window_id;
    }

    /// <summary>ardy_planner_stats.</summary>
    [StructLayout(LayoutKind.Sequential)]
    public struct PlannerStats
    {
        public ulong windows_started;
        public ulong windows_published;
        public ulong splices;
        public ulong late_windows;
        public ulong cancelled_windows;
        public ulong failed_windows;
        public ulong commands;
        public ulong errors;
        public double last_latency_seconds;
        public double latency_estimate_seconds;
        public long buffer_frames;
        public double underrun_seconds;
        public double playhead;
        public double queued_seconds;
        [MarshalAs(UnmanagedType.U1)] public bool window_in_flight;
    }

    internal static unsafe class NativeMethods
    {
        internal const string Library = "ardy_c";
        /// <summary>The ARDY_ABI_VERSION these declarations were written for.</summary>
        internal const int AbiVersion = 4;

        // --- library ---------------------------------------------------------
        [DllImport(Library)] internal static extern IntPtr ardy_version();
        [DllImport(Library)] internal static extern int ardy_abi_version();
        [DllImport(Library)] internal static extern IntPtr ardy_onnxruntime_version();
        [DllImport(Library)] internal static extern IntPtr ardy_status_name(Status status);
        [DllImport(Library)] internal static extern IntPtr ardy_last_error();

        // --- model -----------------------------------------------------------
        [DllImport(Library)] internal static extern ardy_model_params ardy_model_default_params();
        [DllImport(Library)]
        internal static extern Status ardy_model_load_from_folder([MarshalAs(UnmanagedType.LPUTF8Str)] string path,
                                                                  ardy_model_params* parameters, out ModelHandle model);
        [DllImport(Library)]
        internal static extern Status ardy_model_load_from_memory(ardy_file_buffer* files, UIntPtr file_count,
                                                                  [MarshalAs(UnmanagedType.LPUTF8Str)] string name,
                                                                  ardy_model_params* parameters, out ModelHandle model);
        [DllImport(Library)] internal static extern void ardy_model_free(IntPtr model);
        [DllImport(Library)] internal static extern IntPtr ardy_model_last_error(ModelHandle model);
        [DllImport(Library)] internal static extern double ardy_model_fps(ModelHandle model);
        [DllImport(Library)] internal static extern double ardy_model_window_seconds(ModelHandle model);
        [DllImport(Library)] internal static extern UIntPtr ardy_model_joint_count(ModelHandle model);
        [DllImport(Library)] internal static extern IntPtr ardy_model_joint_name(ModelHandle model, UIntPtr joint);
        [DllImport(Library)] internal static extern int ardy_model_joint_parent(ModelHandle model, UIntPtr joint);
        [DllImport(Library)]
        internal static extern int ardy_model_joint_index(ModelHandle model, [MarshalAs(UnmanagedType.LPUTF8Str)] string name);
        [DllImport(Library)] internal static extern Status ardy_model_joint_offset(ModelHandle model, UIntPtr joint, float* xyz);
        [DllImport(Library)] internal static extern UIntPtr ardy_model_contact_count(ModelHandle model);
        [DllImport(Library)] internal static extern IntPtr ardy_model_contact_name(ModelHandle model, UIntPtr contact);
        [DllImport(Library)] internal static extern UIntPtr ardy_model_feature_size(ModelHandle model);

        // --- planner params ----------------------------------------------------
        [DllImport(Library)] internal static extern ardy_planner_params ardy_planner_default_params();

        // --- batcher -----------------------------------------------------------
        [DllImport(Library)] internal static extern ardy_batcher_params ardy_batcher_default_params();
        [DllImport(Library)]
        internal static extern Status ardy_batcher_create(ardy_batcher_params* parameters, out BatcherHandle batcher);
        [DllImport(Library)] internal static extern void ardy_batcher_free(IntPtr batcher);
        [DllImport(Library)] internal static extern Status ardy_batcher_get_stats(BatcherHandle batcher, out BatcherStats stats);

        // --- planner -----------------------------------------------------------
        [DllImport(Library)]
        internal static extern Status ardy_planner_create(ModelHandle model, ardy_planner_params* parameters,
                                                          out PlannerHandle planner);
        [DllImport(Library)] internal static extern void ardy_planner_free(IntPtr planner);
        [DllImport(Library)] internal static extern IntPtr ardy_planner_last_error(PlannerHandle planner);
        [DllImport(Library)]
        [return: MarshalAs(UnmanagedType.U1)]
        internal static extern bool ardy_planner_pop_error(PlannerHandle planner, byte* buffer, UIntPtr capacity);

        [DllImport(Library)]
        internal static extern Status ardy_planner_set_prompt(PlannerHandle planner, [MarshalAs(UnmanagedType.LPUTF8Str)] string text);
        [DllImport(Library)]
        internal static extern Status ardy_planner_set_prompt_at(PlannerHandle planner, double time,
                                                                 [MarshalAs(UnmanagedType.LPUTF8Str)] string text);

        [DllImport(Library)]
        internal static extern Status ardy_planner_add_waypoint(PlannerHandle planner, double time, double x, double z,
                                                                [MarshalAs(UnmanagedType.U1)] bool has_heading,
                                                                double heading, out ulong id);
        [DllImport(Library)]
        internal static extern Status ardy_planner_add_path(PlannerHandle planner, double start_time, double* points_xz,
                                                            UIntPtr point_count, double speed,
                                                            [MarshalAs(UnmanagedType.U1)] bool smooth, out ulong id);
        [DllImport(Library)]
        internal static extern Status ardy_planner_add_path_frames(PlannerHandle planner, double start_time,
                                                                   double* positions_xz, UIntPtr frame_count,
                                                                   double* headings, out ulong id);
        [DllImport(Library)]
        internal static extern Status ardy_planner_add_joint_target(PlannerHandle planner, double time,
                                                                    [MarshalAs(UnmanagedType.LPUTF8Str)] string joint,
                                                                    double* position, double* rotation_xyzw,
                                                                    double* root_xz, out ulong id);
        [DllImport(Library)]
        internal static extern Status ardy_planner_add_keyframe(PlannerHandle planner, double time, float* root_position,
                                                                float heading, float* local_rotations_xyzw,
                                                                UIntPtr joint_count,
                                                                [MarshalAs(UnmanagedType.U1)] bool include_root,
                                                                out ulong id);
        [DllImport(Library)]
        internal static extern Status ardy_planner_add_keyframe_features(PlannerHandle planner, double time,
                                                                         double* features, UIntPtr feature_count,
                                                                         [MarshalAs(UnmanagedType.U1)] bool include_root,
                                                                         out ulong id);
        [DllImport(Library)]
        internal static extern Status ardy_planner_add_contact(PlannerHandle planner, double start_time, double end_time,
                                                               IntPtr* feet, UIntPtr foot_count, double value,
                                                               out ulong id);
        [DllImport(Library)] internal static extern Status ardy_planner_remove_constraint(PlannerHandle planner, ulong id);
        [DllImport(Library)] internal static extern Status ardy_planner_clear_constraints(PlannerHandle planner);

        [DllImport(Library)] internal static extern Status ardy_planner_set_target_velocity(PlannerHandle planner, double vx, double vz);
        [DllImport(Library)] internal static extern Status ardy_planner_clear_target_velocity(PlannerHandle planner);
        [DllImport(Library)]
        internal static extern Status ardy_planner_set_sampling(PlannerHandle planner, int steps, float w_text, float w_con,
                                                                float path_guidance_scale, float text_only_guidance_scale);

        // --- playback ------------------------------------------------------------
        [DllImport(Library)] internal static extern Status ardy_planner_advance(PlannerHandle planner, double delta);
        [DllImport(Library)] internal static extern double ardy_planner_time(PlannerHandle planner);
        [DllImport(Library)] internal static extern double ardy_planner_queued_seconds(PlannerHandle planner);
        [DllImport(Library)]
        internal static extern Status ardy_planner_sample(PlannerHandle planner, double time, PoseInfo* info,
                                                          float* local_rotations_xyzw, float* world_positions_xyz,
                                                          float* contacts, UIntPtr joint_capacity,
                                                          UIntPtr contact_capacity);
        [DllImport(Library)]
        internal static extern Status ardy_planner_sample_current(PlannerHandle planner, PoseInfo* info,
                                                                  float* local_rotations_xyzw, float* world_positions_xyz,
                                                                  float* contacts, UIntPtr joint_capacity,
                                                                  UIntPtr contact_capacity);
        [DllImport(Library)] internal static extern Status ardy_planner_get_stats(PlannerHandle planner, out PlannerStats stats);
        [DllImport(Library)] internal static extern Status ardy_planner_wait_idle(PlannerHandle planner, double timeout_seconds);
    }

    /// <summary>Owns an ardy_model*; ardy_model_free on release (also from the finalizer).</summary>
    public sealed class ModelHandle : SafeHandle
    {
        public ModelHandle() : base(IntPtr.Zero, true) { }
        public override bool IsInvalid { get { return handle == IntPtr.Zero; } }
        protected override bool ReleaseHandle() { NativeMethods.ardy_model_free(handle); return true; }
    }

    /// <summary>Owns an ardy_planner*; ardy_planner_free on release (cancels the window in flight, joins the worker).</summary>
    public sealed class PlannerHandle : SafeHandle
    {
        public PlannerHandle() : base(IntPtr.Zero, true) { }
        public override bool IsInvalid { get { return handle == IntPtr.Zero; } }
        protected override bool ReleaseHandle() { NativeMethods.ardy_planner_free(handle); return true; }
    }

    /// <summary>Owns an ardy_batcher*; ardy_batcher_free on release (waits for the batch in flight).</summary>
    public sealed class BatcherHandle : SafeHandle
    {
        public BatcherHandle() : base(IntPtr.Zero, true) { }
        public override bool IsInvalid { get { return handle == IntPtr.Zero; } }
        protected override bool ReleaseHandle() { NativeMethods.ardy_batcher_free(handle); return true; }
    }

    /// <summary>UTF-8 strings the library returns (const char*), copied into managed strings.</summary>
    internal static unsafe class Utf8
    {
        internal static string FromNative(IntPtr text)
        {
            if (text == IntPtr.Zero) return null;
            byte* p = (byte*)text;
            int n = 0;
            while (p[n] != 0) ++n;
            return n == 0 ? string.Empty : Encoding.UTF8.GetString(p, n);
        }

        /// <summary>A NUL-terminated UTF-8 copy in unmanaged memory (Marshal.FreeHGlobal it).</summary>
        internal static IntPtr ToHGlobal(string text)
        {
            byte[] bytes = Encoding.UTF8.GetBytes(text);
            IntPtr p = Marshal.AllocHGlobal(bytes.Length + 1);
            Marshal.Copy(bytes, 0, p, bytes.Length);
            ((byte*)p)[bytes.Length] = 0;
            return p;
        }
    }
}
