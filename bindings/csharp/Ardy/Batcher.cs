using System;

namespace Ardy
{
    /// <summary>Runs several planners' windows as one batch (ardy_batcher*): pass it in
    /// PlannerParams.Batcher. A planner keeps the Batcher object reachable; disposing it
    /// explicitly while planners use it makes their next windows fail ("the window batcher
    /// is gone", see Planner.TryPopError).</summary>
    public sealed class Batcher : IDisposable
    {
        private readonly BatcherHandle _handle;
        public BatcherHandle Handle { get { return _handle; } }

        public unsafe Batcher(BatcherParams parameters = null)
        {
            BatcherHandle handle;
            Status status;
            if (parameters != null)
            {
                ardy_batcher_params p = parameters.ToNative();
                status = NativeMethods.ardy_batcher_create(&p, out handle);
            }
            else
            {
                status = NativeMethods.ardy_batcher_create(null, out handle);
            }
            if (status != Status.Ok)
            {
                ArdyException error = ArdyException.FromLastError(status);
                if (handle != null) handle.Dispose();
                throw error;
            }
            _handle = handle;
        }

        public BatcherStats GetStats()
        {
            BatcherStats stats;
            Status s = NativeMethods.ardy_batcher_get_stats(_handle, out stats);
            if (s != Status.Ok) throw ArdyException.FromLastError(s);
            return stats;
        }

        /// <summary>Waits for the batch in flight and frees the batcher.</summary>
        public void Dispose() { _handle.Dispose(); }
        public bool IsDisposed { get { return _handle.IsClosed; } }
    }
}
