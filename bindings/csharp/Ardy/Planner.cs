using System;
using System.Runtime.InteropServices;

namespace Ardy
{
    /// <summary>One character's streaming planner (ardy_planner*). Its worker thread generates
    /// motion ahead of the playhead; a frame loop calls Advance and SampleCurrent, which never
    /// wait on inference and allocate nothing (managed or native). All methods are thread-safe.
    /// A failing call throws ArdyException with the library's message and leaves the planner
    /// usable. Errors of the worker (a window that failed) are queued: TryPopError.</summary>
    public sealed class Planner : IDisposable
    {
        private readonly PlannerHandle _handle;
        private readonly Model _model;       // keeps the Model (and its handle) reachable
        private readonly Batcher _batcher;   // keeps the Batcher from being finalized while the planner lives
        private readonly byte[] _errorBuffer = new byte[4096];
        private readonly int _jointCount;
        private readonly int _contactCount;

        public PlannerHandle Handle { get { return _handle; } }
        public Model Model { get { return _model; } }
        public Batcher Batcher { get { return _batcher; } }
        public int JointCount { get { return _jointCount; } }
        public int ContactCount { get { return _contactCount; } }

        /// <summary>ardy_planner_create: starts the worker; the first window is generated at once.
        /// parameters null: the defaults.</summary>
        public unsafe Planner(Model model, PlannerParams parameters = null)
        {
            if (model == null) throw new ArgumentNullException("model");
            PlannerParams pp = parameters ?? PlannerParams.Default();
            ardy_planner_params p = pp.ToNative();
            bool batcherRef = false;
            Status status;
            PlannerHandle handle;
            try
            {
                if (pp.Batcher != null)
                {
                    pp.Batcher.Handle.DangerousAddRef(ref batcherRef);
                    p.batcher = pp.Batcher.Handle.DangerousGetHandle();
                }
                float[] history = pp.InitialHistory;
                if (history != null && p.initial_history_frames == 0 && model.FeatureSize > 0)
                    p.initial_history_frames = (uint)(history.Length / model.FeatureSize);
                if (history != null && (long)p.initial_history_frames * model.FeatureSize > history.Length)
                    throw new ArgumentException("InitialHistory holds " + history.Length + " values, InitialHistoryFrames " +
                                                p.initial_history_frames + " frames need " +
                                                (long)p.initial_history_frames * model.FeatureSize, "parameters");
                fixed (float* h = history)
                {
                    p.initial_history = (IntPtr)h;  // copied by the library
                    status = NativeMethods.ardy_planner_create(model.Handle, &p, out handle);
                }
            }
            finally
            {
                if (batcherRef) pp.Batcher.Handle.DangerousRelease();
            }
            if (status != Status.Ok)
            {
                ArdyException error = ArdyException.FromLastError(status);
                if (handle != null) handle.Dispose();
                throw error;
            }
            _handle = handle;
            _model = model;
            _batcher = pp.Batcher;
            _jointCount = model.JointCount;
            _contactCount = model.ContactCount;
        }

        // --- errors ----------------------------------------------------------------

        /// <summary>This handle's last failing call's message; else the latest worker error; "" if none.</summary>
        public string LastError { get { return Utf8.FromNative(NativeMethods.ardy_planner_last_error(_handle)); } }

        private void Check(Status status)
        {
            if (status != Status.Ok) throw new ArdyException(status, LastError);
        }

        /// <summary>Pops the oldest queued worker error (a window that failed). false when none
        /// (no allocation then: poll it every frame).</summary>
        public unsafe bool TryPopError(out string message)
        {
            lock (_errorBuffer)
            {
                bool popped;
                fixed (byte* b = _errorBuffer)
                {
                    popped = NativeMethods.ardy_planner_pop_error(_handle, b, (UIntPtr)_errorBuffer.Length);
                    message = popped ? Utf8.FromNative((IntPtr)b) : null;
                }
                return popped;
            }
        }

        // --- prompts -----------------------------------------------------------------

        /// <summary>Takes effect after the replan buffer; null clears the prompt.</summary>
        public void SetPrompt(string text) { Check(NativeMethods.ardy_planner_set_prompt(_handle, text)); }

        /// <summary>Takes effect at the first token boundary at or after time (a past time: now); null: no prompt from then on.</summary>
        public void SetPromptAt(double time, string text) { Check(NativeMethods.ardy_planner_set_prompt_at(_handle, time, text)); }

        // --- constraints (times in planner seconds; each returns an id for RemoveConstraint) --

        /// <summary>The root at (x, z) at time; heading (radians, 0 faces +Z) when given.</summary>
        public ulong AddWaypoint(double time, double x, double z, double? heading = null)
        {
            ulong id;
            Check(NativeMethods.ardy_planner_add_waypoint(_handle, time, x, z, heading.HasValue,
                                                         heading.HasValue ? heading.Value : 0.0, out id));
            return id;
        }

        /// <summary>A path at speed m/s through (x, z) points (pointsXz: x0, z0, x1, z1, ...).
        /// smooth: mouse-style clicks, interpolated then smoothed.</summary>
        public unsafe ulong AddPath(double startTime, double[] pointsXz, double speed, bool smooth)
        {
            if (pointsXz == null) throw new ArgumentNullException("pointsXz");
            ulong id;
            fixed (double* p = pointsXz)
                Check(NativeMethods.ardy_planner_add_path(_handle, startTime, p, (UIntPtr)(pointsXz.Length / 2), speed,
                                                          smooth, out id));
            return id;
        }

        /// <summary>One (x, z) per model frame from startTime; headings null or one per frame.</summary>
        public unsafe ulong AddPathFrames(double startTime, double[] positionsXz, double[] headings = null)
        {
            if (positionsXz == null) throw new ArgumentNullException("positionsXz");
            int frames = positionsXz.Length / 2;
            if (headings != null && headings.Length < frames)
                throw new ArgumentException("headings needs one value per frame (" + frames + ")", "headings");
            ulong id;
            fixed (double* p = positionsXz)
            fixed (double* h = headings)
                Check(NativeMethods.ardy_planner_add_path_frames(_handle, startTime, p, (UIntPtr)frames, h, out id));
            return id;
        }

        /// <summary>Position (x, y, z) and/or world rotation (x, y, z, w) of a joint at time; either may be
        /// null, not both. Non-root position: relative to the root's ground projection, or world space
        /// when rootXz (x, z) is given.</summary>
        public unsafe ulong AddJointTarget(double time, string joint, double[] position, double[] rotationXyzw,
                                           double[] rootXz = null)
        {
            if (position != null && position.Length < 3) throw new ArgumentException("position needs 3 values", "position");
            if (rotationXyzw != null && rotationXyzw.Length < 4)
                throw new ArgumentException("rotationXyzw needs 4 values", "rotationXyzw");
            if (rootXz != null && rootXz.Length < 2) throw new ArgumentException("rootXz needs 2 values", "rootXz");
            ulong id;
            fixed (double* p = position)
            fixed (double* r = rotationXyzw)
            fixed (double* x = rootXz)
                Check(NativeMethods.ardy_planner_add_joint_target(_handle, time, joint, p, r, x, out id));
            return id;
        }

        /// <summary>A full-body keyframe from a pose: root position (x, y, z), heading, and the local
        /// rotations of every joint (JointCount * 4 floats, xyzw), e.g. as sampled.</summary>
        public unsafe ulong AddKeyframe(double time, float[] rootPosition, float heading, float[] localRotationsXyzw,
                                        bool includeRoot)
        {
            if (rootPosition == null || rootPosition.Length < 3) throw new ArgumentException("rootPosition needs 3 values", "rootPosition");
            if (localRotationsXyzw == null) throw new ArgumentNullException("localRotationsXyzw");
            ulong id;
            fixed (float* root = rootPosition)
            fixed (float* q = localRotationsXyzw)
                Check(NativeMethods.ardy_planner_add_keyframe(_handle, time, root, heading, q,
                                                              (UIntPtr)(localRotationsXyzw.Length / 4), includeRoot, out id));
            return id;
        }

        /// <summary>A full-body keyframe as world explicit features (Model.FeatureSize values).</summary>
        public unsafe ulong AddKeyframeFeatures(double time, double[] features, bool includeRoot)
        {
            if (features == null) throw new ArgumentNullException("features");
            ulong id;
            fixed (double* f = features)
                Check(NativeMethods.ardy_planner_add_keyframe_features(_handle, time, f, (UIntPtr)features.Length,
                                                                       includeRoot, out id));
            return id;
        }

        /// <summary>Foot contacts over [startTime, endTime); feet by contact name (Model.ContactName);
        /// feet null or empty: all of them.</summary>
        public unsafe ulong AddContact(double startTime, double endTime, string[] feet, double value)
        {
            int n = feet == null ? 0 : feet.Length;
            var names = new IntPtr[n];
            try
            {
                for (int i = 0; i < n; ++i) names[i] = feet[i] == null ? IntPtr.Zero : Utf8.ToHGlobal(feet[i]);
                ulong id;
                fixed (IntPtr* f = names)
                    Check(NativeMethods.ardy_planner_add_contact(_handle, startTime, endTime, n == 0 ? null : f,
                                                                 (UIntPtr)n, value, out id));
                return id;
            }
            finally
            {
                for (int i = 0; i < n; ++i)
                    if (names[i] != IntPtr.Zero) Marshal.FreeHGlobal(names[i]);
            }
        }

        /// <summary>Unknown ids are ignored.</summary>
        public void RemoveConstraint(ulong id) { Check(NativeMethods.ardy_planner_remove_constraint(_handle, id)); }
        public void ClearConstraints() { Check(NativeMethods.ardy_planner_clear_constraints(_handle)); }

        /// <summary>Keyboard steering: target root velocity (m/s, world x and z).</summary>
        public void SetTargetVelocity(double vx, double vz) { Check(NativeMethods.ardy_planner_set_target_velocity(_handle, vx, vz)); }
        public void ClearTargetVelocity() { Check(NativeMethods.ardy_planner_clear_target_velocity(_handle)); }

        /// <summary>Sampling of the windows to come: steps 0, a NaN value: unchanged
        /// (pathGuidanceScale: PlannerParams.PathGuidanceScale, textOnlyGuidanceScale:
        /// PlannerParams.TextOnlyGuidanceScale).</summary>
        public void SetSampling(int steps, float wText = float.NaN, float wCon = float.NaN,
                                float pathGuidanceScale = float.NaN, float textOnlyGuidanceScale = float.NaN)
        {
            Check(NativeMethods.ardy_planner_set_sampling(_handle, steps, wText, wCon, pathGuidanceScale,
                                                                 textOnlyGuidanceScale));
        }

        // --- playback (never waits on inference, never allocates) ----------------------

        /// <summary>Moves the playhead by delta seconds (finite, >= 0), at most to the last generated frame.</summary>
        public void Advance(double delta) { Check(NativeMethods.ardy_planner_advance(_handle, delta)); }

        /// <summary>The playhead, seconds.</summary>
        public double Time { get { return NativeMethods.ardy_planner_time(_handle); } }

        /// <summary>Generated motion ahead of the playhead, seconds.</summary>
        public double QueuedSeconds { get { return NativeMethods.ardy_planner_queued_seconds(_handle); } }

        /// <summary>The pose at the playhead into caller arrays: localRotationsXyzw [JointCount * 4]
        /// (parent-relative; root: world), worldPositionsXyz [JointCount * 3], contacts [ContactCount];
        /// any may be null (skipped). Throws ArdyException (NotReady before the first window,
        /// BufferTooSmall). Allocates nothing.</summary>
        public void SampleCurrent(out PoseInfo info, float[] localRotationsXyzw, float[] worldPositionsXyz, float[] contacts = null)
        {
            Check(TrySampleCurrent(out info, localRotationsXyzw, worldPositionsXyz, contacts));
        }

        /// <summary>The pose at time (clamped to the frames kept); see SampleCurrent.</summary>
        public void Sample(double time, out PoseInfo info, float[] localRotationsXyzw, float[] worldPositionsXyz,
                           float[] contacts = null)
        {
            Check(TrySample(time, out info, localRotationsXyzw, worldPositionsXyz, contacts));
        }

        /// <summary>SampleCurrent without the exception: the status (NotReady before the first window
        /// is normal in a game loop). The message of a failure is LastError.</summary>
        public unsafe Status TrySampleCurrent(out PoseInfo info, float[] localRotationsXyzw, float[] worldPositionsXyz,
                                              float[] contacts = null)
        {
            info = default(PoseInfo);
            fixed (PoseInfo* i = &info)
            fixed (float* q = localRotationsXyzw)
            fixed (float* p = worldPositionsXyz)
            fixed (float* c = contacts)
            {
                return NativeMethods.ardy_planner_sample_current(
                    _handle, i, q, p, c, JointCapacity(localRotationsXyzw == null ? -1 : localRotationsXyzw.Length,
                                                       worldPositionsXyz == null ? -1 : worldPositionsXyz.Length),
                    (UIntPtr)(contacts == null ? 0 : contacts.Length));
            }
        }

        public unsafe Status TrySample(double time, out PoseInfo info, float[] localRotationsXyzw, float[] worldPositionsXyz,
                                       float[] contacts = null)
        {
            info = default(PoseInfo);
            fixed (PoseInfo* i = &info)
            fixed (float* q = localRotationsXyzw)
            fixed (float* p = worldPositionsXyz)
            fixed (float* c = contacts)
            {
                return NativeMethods.ardy_planner_sample(
                    _handle, time, i, q, p, c, JointCapacity(localRotationsXyzw == null ? -1 : localRotationsXyzw.Length,
                                                             worldPositionsXyz == null ? -1 : worldPositionsXyz.Length),
                    (UIntPtr)(contacts == null ? 0 : contacts.Length));
            }
        }

        /// <summary>SampleCurrent into spans (slices of larger buffers, stackalloc, native memory).
        /// An empty span is skipped, like a null array.</summary>
        public unsafe void SampleCurrent(out PoseInfo info, Span<float> localRotationsXyzw, Span<float> worldPositionsXyz,
                                         Span<float> contacts)
        {
            info = default(PoseInfo);
            fixed (PoseInfo* i = &info)
            fixed (float* q0 = &MemoryMarshal.GetReference(localRotationsXyzw))
            fixed (float* p0 = &MemoryMarshal.GetReference(worldPositionsXyz))
            fixed (float* c0 = &MemoryMarshal.GetReference(contacts))
            {
                float* q = localRotationsXyzw.Length == 0 ? null : q0;
                float* p = worldPositionsXyz.Length == 0 ? null : p0;
                float* c = contacts.Length == 0 ? null : c0;
                Check(NativeMethods.ardy_planner_sample_current(
                    _handle, i, q, p, c, JointCapacity(q == null ? -1 : localRotationsXyzw.Length,
                                                       p == null ? -1 : worldPositionsXyz.Length),
                    (UIntPtr)contacts.Length));
            }
        }

        /// <summary>Sample at time into spans; see SampleCurrent(Span).</summary>
        public unsafe void Sample(double time, out PoseInfo info, Span<float> localRotationsXyzw, Span<float> worldPositionsXyz,
                                  Span<float> contacts)
        {
            info = default(PoseInfo);
            fixed (PoseInfo* i = &info)
            fixed (float* q0 = &MemoryMarshal.GetReference(localRotationsXyzw))
            fixed (float* p0 = &MemoryMarshal.GetReference(worldPositionsXyz))
            fixed (float* c0 = &MemoryMarshal.GetReference(contacts))
            {
                float* q = localRotationsXyzw.Length == 0 ? null : q0;
                float* p = worldPositionsXyz.Length == 0 ? null : p0;
                float* c = contacts.Length == 0 ? null : c0;
                Check(NativeMethods.ardy_planner_sample(
                    _handle, time, i, q, p, c, JointCapacity(q == null ? -1 : localRotationsXyzw.Length,
                                                             p == null ? -1 : worldPositionsXyz.Length),
                    (UIntPtr)contacts.Length));
            }
        }

        // One joint_capacity covers both arrays: the joints the smaller one holds (-1: not given).
        private static UIntPtr JointCapacity(int rotationFloats, int positionFloats)
        {
            int joints = int.MaxValue;
            if (rotationFloats >= 0) joints = Math.Min(joints, rotationFloats / 4);
            if (positionFloats >= 0) joints = Math.Min(joints, positionFloats / 3);
            return (UIntPtr)(joints == int.MaxValue ? 0 : joints);
        }

        public PlannerStats GetStats()
        {
            PlannerStats stats;
            Check(NativeMethods.ardy_planner_get_stats(_handle, out stats));
            return stats;
        }

        /// <summary>Blocks until the worker has nothing left to do: true, or false after timeoutSeconds.
        /// For tools, baking and tests; never from a frame loop.</summary>
        public bool WaitIdle(double timeoutSeconds)
        {
            Status s = NativeMethods.ardy_planner_wait_idle(_handle, timeoutSeconds);
            if (s == Status.Timeout) return false;
            Check(s);
            return true;
        }

        /// <summary>Cancels a window in flight (returns within one model call), joins the worker and
        /// frees the planner. Without Dispose the finalizer does it.</summary>
        public void Dispose() { _handle.Dispose(); }
        public bool IsDisposed { get { return _handle.IsClosed; } }
    }
}
