using System;

namespace Ardy
{
    /// <summary>A call of the C ABI failed: Status is what it returned, Message the C message
    /// (ardy_last_error, ardy_model_last_error or ardy_planner_last_error), which says what
    /// was wrong and where. The object the call was made on is unchanged and still usable.</summary>
    public class ArdyException : Exception
    {
        public Status Status { get; private set; }

        public ArdyException(Status status, string message)
            : base(string.IsNullOrEmpty(message) ? Library.StatusName(status) : message)
        {
            Status = status;
        }

        /// <summary>A failing call that had no handle (load, create): ardy_last_error of this thread.</summary>
        internal static ArdyException FromLastError(Status status)
        {
            return new ArdyException(status, Utf8.FromNative(NativeMethods.ardy_last_error()));
        }
    }
}
