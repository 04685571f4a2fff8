using System;
using System.Collections.Generic;
using System.Runtime.InteropServices;

namespace Ardy
{
    /// <summary>One package file given as bytes (ardy_file_buffer): Name is the file name
    /// model.json uses ("model.json", "denoiser.onnx", "vocab.txt", ...).</summary>
    public struct ModelFile
    {
        public string Name;
        public byte[] Data;
        public ModelFile(string name, byte[] data) { Name = name; Data = data; }
    }

    /// <summary>A loaded model package (ardy_model*, immutable, thread-safe). Any number of
    /// planners share it; a planner keeps it alive, so disposing the Model while planners
    /// run is allowed.</summary>
    public sealed class Model : IDisposable
    {
        private readonly ModelHandle _handle;
        private readonly string[] _jointNames;
        private readonly string[] _contactNames;

        public ModelHandle Handle { get { return _handle; } }
        public double Fps { get; private set; }
        /// <summary>One window of generated motion, seconds.</summary>
        public double WindowSeconds { get; private set; }
        public int JointCount { get { return _jointNames.Length; } }
        public int ContactCount { get { return _contactNames.Length; } }
        /// <summary>M, the values of one frame of explicit features (keyframes, initial history).</summary>
        public int FeatureSize { get; private set; }

        private Model(ModelHandle handle)
        {
            _handle = handle;
            Fps = NativeMethods.ardy_model_fps(handle);
            WindowSeconds = NativeMethods.ardy_model_window_seconds(handle);
            FeatureSize = (int)NativeMethods.ardy_model_feature_size(handle);
            _jointNames = new string[(int)NativeMethods.ardy_model_joint_count(handle)];
            for (int j = 0; j < _jointNames.Length; ++j)
                _jointNames[j] = Utf8.FromNative(NativeMethods.ardy_model_joint_name(handle, (UIntPtr)j));
            _contactNames = new string[(int)NativeMethods.ardy_model_contact_count(handle)];
            for (int c = 0; c < _contactNames.Length; ++c)
                _contactNames[c] = Utf8.FromNative(NativeMethods.ardy_model_contact_name(handle, (UIntPtr)c));
        }

        /// <summary>ardy_model_load_from_folder. parameters null: the defaults. Throws ArdyException
        /// (IO, InvalidModel, InvalidArgument) with the library's message, which names the path or field.</summary>
        public static unsafe Model LoadFromFolder(string path, ModelParams parameters = null)
        {
            if (path == null) throw new ArgumentNullException("path");
            ModelHandle handle;
            Status status;
            if (parameters != null)
            {
                ardy_model_params p = parameters.ToNative();
                status = NativeMethods.ardy_model_load_from_folder(path, &p, out handle);
            }
            else
            {
                status = NativeMethods.ardy_model_load_from_folder(path, null, out handle);
            }
            return Wrap(status, handle);
        }

        /// <summary>ardy_model_load_from_memory: the package's files as bytes (e.g. read from an
        /// engine's archive); name is used in messages. The bytes need not outlive the call.</summary>
        public static unsafe Model LoadFromMemory(IList<ModelFile> files, string name, ModelParams parameters = null)
        {
            if (files == null) throw new ArgumentNullException("files");
            int n = files.Count;
            var pins = new GCHandle[n];
            var buffers = new ardy_file_buffer[n];
            try
            {
                for (int i = 0; i < n; ++i)
                {
                    byte[] data = files[i].Data ?? new byte[0];
                    pins[i] = GCHandle.Alloc(data, GCHandleType.Pinned);
                    buffers[i].name = files[i].Name == null ? IntPtr.Zero : Utf8.ToHGlobal(files[i].Name);
                    buffers[i].data = pins[i].AddrOfPinnedObject();
                    buffers[i].size = (UIntPtr)data.Length;
                }
                ModelHandle handle;
                Status status;
                ardy_model_params p = parameters != null ? parameters.ToNative() : NativeMethods.ardy_model_default_params();
                fixed (ardy_file_buffer* b = buffers)
                    status = NativeMethods.ardy_model_load_from_memory(b, (UIntPtr)n, name ?? "memory", &p, out handle);
                return Wrap(status, handle);
            }
            finally
            {
                for (int i = 0; i < n; ++i)
                {
                    if (pins[i].IsAllocated) pins[i].Free();
                    if (buffers[i].name != IntPtr.Zero) Marshal.FreeHGlobal(buffers[i].name);
                }
            }
        }

        private static Model Wrap(Status status, ModelHandle handle)
        {
            if (status != Status.Ok)
            {
                ArdyException error = ArdyException.FromLastError(status);
                if (handle != null) handle.Dispose();
                throw error;
            }
            return new Model(handle);
        }

        /// <summary>The name of joint j (0 .. JointCount-1; 0 is the root, "Hips").</summary>
        public string JointName(int joint) { return _jointNames[joint]; }
        /// <summary>The joint names in the order of the sampled arrays.</summary>
        public string[] JointNames() { return (string[])_jointNames.Clone(); }
        /// <summary>-1: the root.</summary>
        public int JointParent(int joint)
        {
            if (joint < 0 || joint >= _jointNames.Length) throw new ArgumentOutOfRangeException("joint");
            return NativeMethods.ardy_model_joint_parent(_handle, (UIntPtr)joint);
        }
        /// <summary>-1: unknown.</summary>
        public int JointIndex(string name)
        {
            return name == null ? -1 : NativeMethods.ardy_model_joint_index(_handle, name);
        }
        public string ContactName(int contact) { return _contactNames[contact]; }

        /// <summary>Rest offset of a joint in its parent's frame (x, y, z metres) into xyz[0..2].</summary>
        public unsafe void GetJointOffset(int joint, float[] xyz)
        {
            if (xyz == null) throw new ArgumentNullException("xyz");
            if (xyz.Length < 3) throw new ArgumentException("xyz needs 3 values", "xyz");
            if (joint < 0) throw new ArgumentOutOfRangeException("joint");
            Status s;
            fixed (float* p = xyz) s = NativeMethods.ardy_model_joint_offset(_handle, (UIntPtr)joint, p);
            if (s != Status.Ok) throw new ArdyException(s, Utf8.FromNative(NativeMethods.ardy_model_last_error(_handle)));
        }

        /// <summary>Frees the model now (planners made from it keep it alive inside the library).
        /// Without Dispose the finalizer frees it.</summary>
        public void Dispose() { _handle.Dispose(); }
        public bool IsDisposed { get { return _handle.IsClosed; } }
    }
}
