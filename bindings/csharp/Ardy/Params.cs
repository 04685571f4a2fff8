using System;

namespace Ardy
{
    /// <summary>ardy_model_params. Start from ModelParams.Default() (ardy_model_default_params).</summary>
    public sealed class ModelParams
    {
        /// <summary>ONNX Runtime threads per graph call; 0: all cores but one (at least 1).</summary>
        public int IntraOpThreads;
        /// <summary>Prompt embeddings cached; 0 turns the cache off (default 256).</summary>
        public uint TextCacheCapacity;
        /// <summary>Longer prompts are refused (default 2000).</summary>
        public uint MaxPromptChars;
        /// <summary>One spinning intra-op pool for all graphs (default false); only for the first model loaded in the process.</summary>
        public bool FastThreads;

        /// <summary>The library's defaults (ardy_model_default_params).</summary>
        public static ModelParams Default()
        {
            ardy_model_params p = NativeMethods.ardy_model_default_params();
            return new ModelParams {
                IntraOpThreads = p.intra_op_threads,
                TextCacheCapacity = p.text_cache_capacity,
                MaxPromptChars = p.max_prompt_chars,
                FastThreads = p.fast_threads,
            };
        }

        internal ardy_model_params ToNative()
        {
            return new ardy_model_params {
                intra_op_threads = IntraOpThreads,
                text_cache_capacity = TextCacheCapacity,
                max_prompt_chars = MaxPromptChars,
                fast_threads = FastThreads,
            };
        }
    }

    /// <summary>ardy_planner_params. Start from PlannerParams.Default() (ardy_planner_default_params).</summary>
    public sealed class PlannerParams
    {
        /// <summary>Diffusion steps per window; 0: the package default.</summary>
        public int Steps;
        /// <summary>Text guidance; NaN: the package default.</summary>
        public float WText;
        /// <summary>Constraint guidance; NaN: the package default.</summary>
        public float WCon;
        /// <summary>WCon times this where the goals are a dense root path alone (keyboard steering,
        /// clicked paths), in (0, 1]; NaN: the package default.</summary>
        public float PathGuidanceScale;
        /// <summary>WText times this where a window has a prompt and no goals, at the steps in
        /// the upper half of the diffusion schedule, in (0, 4]; NaN: the package default.</summary>
        public float TextOnlyGuidanceScale;
        /// <summary>History window (default 8; clamped to the package's maximum).</summary>
        public double HistorySeconds;
        /// <summary>Out-of-window goal horizon; &lt; 0: the package's maximum.</summary>
        public double FutureSeconds;
        /// <summary>Where the character starts (world x, z).</summary>
        public double StartX, StartZ;
        /// <summary>Noise of the windows.</summary>
        public ulong Seed;
        /// <summary>The replan buffer is at least this many frames.</summary>
        public uint MinBufferFrames;
        /// <summary>Assumed before the first window is measured (default 0.1).</summary>
        public double InitialLatencySeconds;
        /// <summary>Factor on the measured latency (default 1.25).</summary>
        public double LatencyMargin;
        /// <summary>Append a window when less is queued ahead (default 1).</summary>
        public double LowWaterSeconds;
        /// <summary>Frames kept behind the playhead (default 1).</summary>
        public double KeepBehindSeconds;
        /// <summary>Cancel an appended window a new command would replace (default true).</summary>
        public bool CancelObsoleteWindows;
        /// <summary>Output filter sigma in frames; &lt; 0: the package's (default); 0: off.</summary>
        public double OutputSmoothingFrames;
        /// <summary>Sparse root targets become paths: -1 the package's (default), 0 off, 1 on.</summary>
        public int InterpolateRoot;
        /// <summary>Root goals never ask for more (m/s; default 6; 0: no limit).</summary>
        public double MaxRootSpeed;
        /// <summary>Planted feet held in place by leg IK on the output (default true).</summary>
        public bool FootLock;
        /// <summary>null (default): the planner runs its own windows; else they go to this batcher.
        /// The planner keeps the Batcher object reachable (it is not finalized while the planner lives).</summary>
        public Batcher Batcher;
        /// <summary>What the character was doing before: world explicit features, InitialHistoryFrames
        /// frames of Model.FeatureSize values, the last frame just before time 0. Copied at creation.</summary>
        public float[] InitialHistory;
        /// <summary>Frames in InitialHistory (a multiple of the model's patch size, 4); 0 with InitialHistory
        /// set: InitialHistory.Length / Model.FeatureSize.</summary>
        public uint InitialHistoryFrames;

        /// <summary>The library's defaults (ardy_planner_default_params).</summary>
        public static PlannerParams Default()
        {
            ardy_planner_params p = NativeMethods.ardy_planner_default_params();
            return new PlannerParams {
                Steps = p.steps,
                WText = p.w_text,
                WCon = p.w_con,
                PathGuidanceScale = p.path_guidance_scale,
                TextOnlyGuidanceScale = p.text_only_guidance_scale,
                HistorySeconds = p.history_seconds,
                FutureSeconds = p.future_seconds,
                StartX = p.start_x,
                StartZ = p.start_z,
                Seed = p.seed,
                MinBufferFrames = p.min_buffer_frames,
                InitialLatencySeconds = p.initial_latency_seconds,
                LatencyMargin = p.latency_margin,
                LowWaterSeconds = p.low_water_seconds,
                KeepBehindSeconds = p.keep_behind_seconds,
                CancelObsoleteWindows = p.cancel_obsolete_windows,
                OutputSmoothingFrames = p.output_smoothing_frames,
                InterpolateRoot = p.interpolate_root,
                MaxRootSpeed = p.max_root_speed,
                FootLock = p.foot_lock,
                Batcher = null,
                InitialHistory = null,
                InitialHistoryFrames = p.initial_history_frames,
            };
        }

        // batcher and initial_history are filled in by Planner while it holds them.
        internal ardy_planner_params ToNative()
        {
            return new ardy_planner_params {
                steps = Steps,
                w_text = WText,
                w_con = WCon,
                path_guidance_scale = PathGuidanceScale,
                text_only_guidance_scale = TextOnlyGuidanceScale,
                history_seconds = HistorySeconds,
                future_seconds = FutureSeconds,
                start_x = StartX,
                start_z = StartZ,
                seed = Seed,
                min_buffer_frames = MinBufferFrames,
                initial_latency_seconds = InitialLatencySeconds,
                latency_margin = LatencyMargin,
                low_water_seconds = LowWaterSeconds,
                keep_behind_seconds = KeepBehindSeconds,
                cancel_obsolete_windows = CancelObsoleteWindows,
                output_smoothing_frames = OutputSmoothingFrames,
                interpolate_root = InterpolateRoot,
                max_root_speed = MaxRootSpeed,
                foot_lock = FootLock,
                batcher = IntPtr.Zero,
                initial_history = IntPtr.Zero,
                initial_history_frames = InitialHistoryFrames,
            };
        }
    }

    /// <summary>ardy_batcher_params. Start from BatcherParams.Default() (ardy_batcher_default_params).</summary>
    public sealed class BatcherParams
    {
        /// <summary>Wait this long after a batch's first window for others (default 0.002).</summary>
        public double GatherSeconds;
        /// <summary>Windows per batch; a full batch starts at once (default 16).</summary>
        public uint MaxWindows;

        public static BatcherParams Default()
        {
            ardy_batcher_params p = NativeMethods.ardy_batcher_default_params();
            return new BatcherParams { GatherSeconds = p.gather_seconds, MaxWindows = p.max_windows };
        }

        internal ardy_batcher_params ToNative()
        {
            return new ardy_batcher_params { gather_seconds = GatherSeconds, max_windows = MaxWindows };
        }
    }
}
