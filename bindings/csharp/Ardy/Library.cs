using System;

namespace Ardy
{
    /// <summary>Library-wide queries (ardy_version, ardy_abi_version, ...).</summary>
    public static class Library
    {
        /// <summary>The ARDY_ABI_VERSION these bindings were written for.</summary>
        public const int BindingsAbiVersion = NativeMethods.AbiVersion;

        /// <summary>"0.1.0".</summary>
        public static string Version { get { return Utf8.FromNative(NativeMethods.ardy_version()); } }

        /// <summary>ARDY_ABI_VERSION of the loaded libardy_c.</summary>
        public static int AbiVersion { get { return NativeMethods.ardy_abi_version(); } }

        public static string OnnxRuntimeVersion { get { return Utf8.FromNative(NativeMethods.ardy_onnxruntime_version()); } }

        /// <summary>"ARDY_ERROR_IO", ...</summary>
        public static string StatusName(Status status) { return Utf8.FromNative(NativeMethods.ardy_status_name(status)); }

        /// <summary>This thread's last failing call without a handle; "" if none.</summary>
        public static string LastError { get { return Utf8.FromNative(NativeMethods.ardy_last_error()); } }

        /// <summary>Throws when the loaded library's ABI is not the one these bindings declare.</summary>
        public static void CheckAbi()
        {
            int abi = AbiVersion;
            if (abi != BindingsAbiVersion)
                throw new ArdyException(Status.InvalidArgument,
                    "libardy_c has ABI version " + abi + ", these bindings were written for " + BindingsAbiVersion);
        }
    }
}
