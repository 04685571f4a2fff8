// The C# bindings (bindings/csharp/Ardy) on Mono against the real libardy_c.so
// and the shipped model. No test framework: one line per check, "PASS ..." or
// "FAIL ...", figures on "INFO ..." and "bench: ..." lines, and a last line
// "N passed, N failed"; the exit code is the number of failures.
//
//   mono Tests.exe MODEL_FOLDER [LAYOUT_FILE [SYMBOLS_FILE]]
//
// LAYOUT_FILE: the output of layout.c (sizes and field offsets of the header's
// structs as the C compiler lays them out); SYMBOLS_FILE: the ardy_* exports of
// libardy_c.so, one a line (nm -D). run_tests.sh makes both.
using System;
using System.Collections.Generic;
using System.Diagnostics;
using System.IO;
using System.Runtime.CompilerServices;
using System.Runtime.InteropServices;
using System.Threading;
using Ardy;

static class Tests
{
    static int passed, failed;
    static string modelFolder;

    static void Check(bool ok, string what)
    {
        if (ok) { ++passed; Console.WriteLine("PASS " + what); }
        else { ++failed; Console.WriteLine("FAIL " + what); }
    }

    static void Info(string line) { Console.WriteLine("INFO " + line); }

    // Runs body; a stray exception is one failure named after the group.
    static void Group(string name, Action body)
    {
        try { body(); }
        catch (Exception e) { Check(false, name + ": unexpected " + e.GetType().Name + ": " + e.Message); }
    }

    // The call throws ArdyException with this status and a message containing part
    // (the C message); returns it.
    static ArdyException Throws(string what, Status status, string part, Action call)
    {
        try
        {
            call();
            Check(false, what + ": no exception");
            return null;
        }
        catch (ArdyException e)
        {
            Check(e.Status == status && e.Message.Contains(part),
                  what + ": ArdyException " + e.Status + " \"" + e.Message + "\"" +
                  (e.Status == status ? "" : " (expected " + status + ")") +
                  (e.Message.Contains(part) ? "" : " (expected the message to contain \"" + part + "\")"));
            return e;
        }
        catch (Exception e)
        {
            Check(false, what + ": " + e.GetType().Name + " instead of ArdyException: " + e.Message);
            return null;
        }
    }

    static long ResidentBytes()
    {
        string[] statm = File.ReadAllText("/proc/self/statm").Split(' ');
        return long.Parse(statm[1]) * 4096;  // pages; 4 KiB on x86-64 Linux
    }

    static void FullCollect()
    {
        for (int i = 0; i < 3; ++i)
        {
            GC.Collect();
            GC.WaitForPendingFinalizers();
        }
    }

    static int Main(string[] args)
    {
        if (args.Length < 1)
        {
            Console.Error.WriteLine("usage: mono Tests.exe MODEL_FOLDER [LAYOUT_FILE [SYMBOLS_FILE]]");
            return 2;
        }
        modelFolder = args[0];
        Group("library", TestLibrary);
        if (args.Length > 1) Group("layout", () => TestLayout(args[1]));
        else Check(false, "layout: no layout file given (run_tests.sh makes it with layout.c)");
        Group("entry points", () => TestEntryPoints(args.Length > 2 ? args[2] : null));
        Group("defaults", TestDefaults);
        Group("load errors", TestLoadErrors);
        Model model = null;
        Group("model", () => { model = TestModel(); });
        if (model != null)
        {
            Group("stream", () => TestStream(model));
            Group("bad inputs", () => TestBadInputs(model));
            Group("sampling allocations", () => TestSamplingAllocations(model));
            Group("dispose mid-window", () => TestDisposeMidWindow(model));
            Group("batcher", () => TestBatcher(model));
            Group("resident growth", () => TestResidentGrowth(model));
            Group("finalizers", () => TestFinalizers(model));
            Group("load from memory", TestLoadFromMemory);
            model.Dispose();
            Check(model.IsDisposed, "model: disposed");
            Group("disposed", () => {
                try { model.JointIndex("Hips"); Check(false, "disposed model: no exception"); }
                catch (ObjectDisposedException) { Check(true, "disposed model: calls throw ObjectDisposedException"); }
            });
        }
        FullCollect();
        Console.WriteLine(passed + " passed, " + failed + " failed");
        return failed;
    }

    static void TestLibrary()
    {
        Check(Library.Version == "0.1.0", "library: version \"" + Library.Version + "\"");
        Check(Library.AbiVersion == Library.BindingsAbiVersion,
              "library: ABI version " + Library.AbiVersion + " is the bindings' " + Library.BindingsAbiVersion);
        Library.CheckAbi();
        Check(!string.IsNullOrEmpty(Library.OnnxRuntimeVersion), "library: ONNX Runtime " + Library.OnnxRuntimeVersion);
        Check(Library.StatusName(Status.IO) == "ARDY_ERROR_IO", "library: status name ARDY_ERROR_IO");
        Check(Library.StatusName(Status.Timeout) == "ARDY_ERROR_TIMEOUT", "library: status name ARDY_ERROR_TIMEOUT");
    }

    // Every struct of the header: the C# declaration has the C size and every field the C offset.
    static void TestLayout(string path)
    {
        var c = new Dictionary<string, long>();
        foreach (string line in File.ReadAllLines(path))
        {
            string[] kv = line.Split(' ');
            if (kv.Length == 2) c[kv[0]] = long.Parse(kv[1]);
        }
        var types = new Dictionary<string, string> {
            { "ardy_model_params", "Ardy.ardy_model_params" },
            { "ardy_file_buffer", "Ardy.ardy_file_buffer" },
            { "ardy_planner_params", "Ardy.ardy_planner_params" },
            { "ardy_batcher_params", "Ardy.ardy_batcher_params" },
            { "ardy_batcher_stats", "Ardy.BatcherStats" },
            { "ardy_pose_info", "Ardy.PoseInfo" },
            { "ardy_planner_stats", "Ardy.PlannerStats" },
        };
        var assembly = typeof(Model).Assembly;
        foreach (var entry in types)
        {
            Type t = assembly.GetType(entry.Value);
            if (t == null) { Check(false, "layout: " + entry.Value + " not found"); continue; }
            long size = Marshal.SizeOf(t);
            bool ok = c.ContainsKey(entry.Key) && c[entry.Key] == size;
            var wrong = new List<string>();
            int fields = 0;
            foreach (var kv in c)
            {
                if (!kv.Key.StartsWith(entry.Key + ".")) continue;
                ++fields;
                string field = kv.Key.Substring(entry.Key.Length + 1);
                if (field == "root_position") field = "root_position_x";  // float[3] as x, y, z
                long offset;
                try { offset = (long)Marshal.OffsetOf(t, field); }
                catch (ArgumentException) { wrong.Add(field + " missing"); continue; }
                if (offset != kv.Value) wrong.Add(field + " at " + offset + ", C " + kv.Value);
            }
            int declared = t.GetFields(System.Reflection.BindingFlags.Instance | System.Reflection.BindingFlags.Public |
                                        System.Reflection.BindingFlags.NonPublic).Length;
            if (entry.Key == "ardy_pose_info") declared -= 2;  // root_position_y, _z
            if (declared != fields) wrong.Add(declared + " fields declared, C has " + fields);
            Check(ok && wrong.Count == 0, "layout: " + entry.Key + " " + size + " bytes (C " +
                  (c.ContainsKey(entry.Key) ? c[entry.Key].ToString() : "?") + ")" +
                  (wrong.Count == 0 ? ", every field at its C offset" : ": " + string.Join("; ", wrong)));
        }
        Check(c.ContainsKey("sizeof_ardy_status") && c["sizeof_ardy_status"] == 4, "layout: ardy_status is 4 bytes (enum Status : int)");
    }

    // Every declaration binds to an export of libardy_c, and (given the list of its
    // ardy_* exports, from nm) every export is declared.
    static void TestEntryPoints(string symbolsPath)
    {
        Type native = typeof(Model).Assembly.GetType("Ardy.NativeMethods");
        var declared = new HashSet<string>();
        var unbound = new List<string>();
        foreach (var method in native.GetMethods(System.Reflection.BindingFlags.Static | System.Reflection.BindingFlags.NonPublic |
                                                 System.Reflection.BindingFlags.Public))
        {
            if ((method.Attributes & System.Reflection.MethodAttributes.PinvokeImpl) == 0) continue;
            declared.Add(method.Name);
            try { Marshal.Prelink(method); }
            catch (Exception e) { unbound.Add(method.Name + " (" + e.GetType().Name + ")"); }
        }
        Check(declared.Count > 0 && unbound.Count == 0, "entry points: all " + declared.Count + " declarations bind to libardy_c" +
              (unbound.Count == 0 ? "" : "; unbound: " + string.Join(", ", unbound)));
        if (symbolsPath == null) return;
        var exported = new HashSet<string>();
        foreach (string line in File.ReadAllLines(symbolsPath))
            if (line.Trim().Length > 0) exported.Add(line.Trim());
        var missing = new List<string>();
        foreach (string name in exported) if (!declared.Contains(name)) missing.Add(name);
        Check(exported.Count > 0 && missing.Count == 0, "entry points: every one of the " + exported.Count +
              " ardy_* exports is declared" + (missing.Count == 0 ? "" : "; not declared: " + string.Join(", ", missing)));
    }

    static void TestDefaults()
    {
        ModelParams mp = ModelParams.Default();
        Check(mp.TextCacheCapacity == 256 && mp.MaxPromptChars == 2000 && !mp.FastThreads && mp.IntraOpThreads == 0,
              "defaults: model params (cache 256, prompt 2000 chars, fast_threads off)");
        PlannerParams pp = PlannerParams.Default();
        Check(pp.HistorySeconds == 8.0 && float.IsNaN(pp.WText) && float.IsNaN(pp.WCon) && float.IsNaN(pp.PathGuidanceScale) &&
              float.IsNaN(pp.TextOnlyGuidanceScale) &&
              pp.MaxRootSpeed == 6.0 &&
              pp.FootLock && pp.CancelObsoleteWindows && pp.InterpolateRoot == -1 && pp.OutputSmoothingFrames < 0.0 &&
              pp.LatencyMargin == 1.25 && pp.LowWaterSeconds == 1.0 && pp.KeepBehindSeconds == 1.0 &&
              pp.InitialLatencySeconds == 0.1 && pp.Batcher == null && pp.InitialHistory == null,
              "defaults: planner params as the header documents them (bools and doubles after them read right)");
        BatcherParams bp = BatcherParams.Default();
        Check(bp.MaxWindows == 16 && Math.Abs(bp.GatherSeconds - 0.002) < 1e-12, "defaults: batcher params (16 windows, 0.002 s)");
    }

    static void TestLoadErrors()
    {
        Throws("bad model path", Status.IO, "/no/such/ardy_package", () => Model.LoadFromFolder("/no/such/ardy_package"));
        Throws("bad model path message", Status.IO, "does not exist", () => Model.LoadFromFolder("/no/such/ardy_package"));
        Throws("folder without model.json", Status.IO, "no model.json", () => Model.LoadFromFolder("/tmp"));
        var bad = ModelParams.Default();
        bad.IntraOpThreads = -3;
        Throws("bad model params", Status.InvalidArgument, "intra_op_threads is -3", () => Model.LoadFromFolder(modelFolder, bad));
        Throws("memory package without its graphs", Status.InvalidModel, "partial", () => Model.LoadFromMemory(
            new[] { new ModelFile("model.json", File.ReadAllBytes(Path.Combine(modelFolder, "model.json"))) }, "partial"));
    }

    static Model TestModel()
    {
        var p = ModelParams.Default();
        var watch = Stopwatch.StartNew();
        Model model = Model.LoadFromFolder(modelFolder, p);
        Info("model loaded in " + watch.ElapsedMilliseconds + " ms: " + model.JointCount + " joints, " + model.Fps +
             " fps, window " + model.WindowSeconds + " s, " + model.FeatureSize + " features, " + model.ContactCount + " contacts");
        Check(model.JointCount == 21 && model.JointName(0) == "Hips", "model: 21 joints, the root is Hips");
        Check(model.JointIndex("Hand_R") == 12 && model.JointIndex("Hand") == -1 && model.JointParent(0) == -1 &&
              model.JointParent(1) == 0, "model: joint index and parent");
        Check(model.Fps == 20.0 && model.WindowSeconds > 0.0 && model.FeatureSize > 0, "model: fps 20, window and feature size");
        Check(model.ContactCount > 0 && model.ContactName(0).StartsWith("Foot"), "model: contacts (" + model.ContactName(0) + ")");
        var offset = new float[3];
        model.GetJointOffset(1, offset);
        Check(!float.IsNaN(offset[1]) && offset[1] != 0.0f, "model: joint offset of Spine " + offset[1] + " m up");
        Throws("joint offset out of range", Status.InvalidArgument, "joint 99 is out of range", () => model.GetJointOffset(99, offset));
        return model;
    }

    // 10 s of motion at 60 fps, paced like a game (real time, never ahead of
    // the generated motion): "walk forward", a waypoint, then "wave with the
    // right hand".
    static void TestStream(Model model)
    {
        int joints = model.JointCount;
        int hips = model.JointIndex("Hips"), hand = model.JointIndex("Hand_R"), head = model.JointIndex("Head");
        var rotations = new float[joints * 4];
        var positions = new float[joints * 3];
        var contacts = new float[model.ContactCount];
        var pp = PlannerParams.Default();
        pp.Seed = 3;
        using (var planner = new Planner(model, pp))
        {
            Check(planner.Model == model && planner.JointCount == joints, "stream: planner made");
            planner.SetPrompt("walk forward");
            // Not ready until the first window (a game would show its rest pose meanwhile).
            PoseInfo info;
            var deadline = Stopwatch.StartNew();
            while (planner.TrySampleCurrent(out info, rotations, positions, contacts) == Status.NotReady &&
                   deadline.Elapsed.TotalSeconds < 60)
                Thread.Sleep(2);
            Check(planner.TrySampleCurrent(out info, rotations, positions, contacts) == Status.Ok,
                  "stream: first window in " + deadline.ElapsedMilliseconds + " ms");

            const double dt = 1.0 / 60.0;
            const int frames = 600;
            const double waypointTime = 4.0, waveTime = 5.0;
            double wx = 0, wz = 0;
            bool waypointSet = false, waveSet = false;
            var times = new double[frames + 1];
            var hipsXz = new double[(frames + 1) * 2];
            var handY = new double[frames + 1];
            var headY = new double[frames + 1];
            double sampleTicks = 0;
            long samples = 0, waits = 0;
            string error;
            int workerErrors = 0;
            var clock = Stopwatch.StartNew();
            for (int f = 0; f <= frames; ++f)
            {
                if (f > 0)
                {
                    // The game's frame: real time, and never past the generated motion.
                    while (clock.Elapsed.TotalSeconds < f * dt || planner.QueuedSeconds < dt - 1e-9)
                    {
                        if (clock.Elapsed.TotalSeconds > 180) break;
                        if (planner.QueuedSeconds < dt - 1e-9) ++waits;
                        Thread.Sleep(1);
                    }
                    planner.Advance(dt);
                }
                long t0 = Stopwatch.GetTimestamp();
                planner.SampleCurrent(out info, rotations, positions, contacts);
                sampleTicks += Stopwatch.GetTimestamp() - t0;
                ++samples;
                while (planner.TryPopError(out error)) { ++workerErrors; Info("worker error: " + error); }
                times[f] = info.time;
                hipsXz[2 * f] = positions[3 * hips];
                hipsXz[2 * f + 1] = positions[3 * hips + 2];
                handY[f] = positions[3 * hand + 1];
                headY[f] = positions[3 * head + 1];
                if (!waypointSet && info.time >= 0.5)
                {
                    // 2 m ahead of where the walk would take it and 1 m to the side.
                    wx = info.root_position_x + 1.0;
                    wz = info.root_position_z + 4.0;
                    planner.AddWaypoint(waypointTime, wx, wz);
                    waypointSet = true;
                }
                if (!waveSet && info.time >= waveTime)
                {
                    planner.SetPrompt("wave with the right hand");
                    waveSet = true;
                }
            }
            double wall = clock.Elapsed.TotalSeconds;
            Check(Math.Abs(planner.Time - frames * dt) < 1e-6, "stream: played " + planner.Time.ToString("F3") + " s in " +
                  wall.ToString("F1") + " s wall (" + waits + " polls waiting for motion)");
            Check(workerErrors == 0, "stream: no worker errors");
            double closest = double.MaxValue, closestAt = 0;
            for (int f = 0; f <= frames; ++f)
            {
                double dx = hipsXz[2 * f] - wx, dz = hipsXz[2 * f + 1] - wz;
                double d = Math.Sqrt(dx * dx + dz * dz);
                if (d < closest) { closest = d; closestAt = times[f]; }
            }
            Info("waypoint (" + wx.ToString("F2") + ", " + wz.ToString("F2") + ") at " + waypointTime + " s: closest approach " +
                 closest.ToString("F3") + " m at " + closestAt.ToString("F2") + " s");
            Check(closest < 0.3, "stream: the hips reach the waypoint (closest " + closest.ToString("F3") + " m, under 0.3 m)");

            // The prompt change: slower hips, a raised right hand.
            Func<double, double, double> speed = (from, to) => {
                double dist = 0; int a = -1, b = -1;
                for (int f = 1; f <= frames; ++f)
                {
                    if (times[f] < from || times[f] > to) continue;
                    if (a < 0) a = f - 1;
                    b = f;
                    double dx = hipsXz[2 * f] - hipsXz[2 * f - 2], dz = hipsXz[2 * f + 1] - hipsXz[2 * f - 1];
                    dist += Math.Sqrt(dx * dx + dz * dz);
                }
                return a < 0 ? 0 : dist / (times[b] - times[a]);
            };
            Func<double, double, double> handAboveHead = (from, to) => {
                double best = double.MinValue;
                for (int f = 0; f <= frames; ++f)
                    if (times[f] >= from && times[f] <= to) best = Math.Max(best, handY[f] - headY[f]);
                return best;
            };
            double walkSpeed = speed(1.0, 4.5), waveSpeed = speed(7.5, 10.0);
            double walkHand = handAboveHead(1.0, 4.5), waveHand = handAboveHead(6.5, 10.0);
            Info("hips speed " + walkSpeed.ToString("F2") + " m/s walking, " + waveSpeed.ToString("F2") +
                 " m/s after \"wave with the right hand\"; right hand highest " + walkHand.ToString("F2") + " m vs " +
                 waveHand.ToString("F2") + " m relative to the head");
            Check(waveSpeed < 0.6 * walkSpeed || waveHand > walkHand + 0.15,
                  "stream: the prompt change changes the motion (hips slower or the right hand raised)");
            var stats = planner.GetStats();
            Info("planner: " + stats.windows_published + " windows, " + stats.splices + " splices, " + stats.late_windows +
                 " late, latency " + stats.latency_estimate_seconds.ToString("F3") + " s, underrun " +
                 stats.underrun_seconds.ToString("F3") + " s, commands " + stats.commands);
            Check(stats.windows_published >= 4 && stats.commands == 3 && stats.errors == 0 &&
                  Math.Abs(stats.playhead - planner.Time) < 1e-9, "stream: stats read through the struct");
            Console.WriteLine("bench: csharp sample_current (21 joints, rotations+positions+contacts, while streaming) " +
                              (sampleTicks * 1e6 / Stopwatch.Frequency / samples).ToString("F2") + " us/frame");
        }
    }

    static void TestBadInputs(Model model)
    {
        int joints = model.JointCount;
        var rotations = new float[joints * 4];
        var positions = new float[joints * 3];
        using (var planner = new Planner(model))
        {
            Check(planner.WaitIdle(60.0), "bad inputs: first window");
            PoseInfo info;
            Throws("NaN sample time", Status.InvalidArgument, "NaN", () => planner.Sample(double.NaN, out info, rotations, positions));
            Throws("NaN advance", Status.InvalidArgument, "advance: delta is NaN", () => planner.Advance(double.NaN));
            Throws("NaN waypoint", Status.InvalidArgument, "x is NaN", () => planner.AddWaypoint(2.0, double.NaN, 0.0));
            Throws("unknown joint", Status.InvalidArgument, "unknown joint 'Hand'",
                   () => planner.AddJointTarget(1.5, "Hand", new[] { 0.3, 1.4, 0.2 }, null));
            Throws("unknown foot", Status.InvalidArgument, "unknown foot 'Foot_X'",
                   () => planner.AddContact(1.0, 2.0, new[] { "Foot_X" }, 1.0));
            Throws("empty prompt", Status.InvalidArgument, "prompt is empty", () => planner.SetPrompt(""));
            Throws("small buffer", Status.BufferTooSmall, "hold 20 joints, the model has 21",
                   () => planner.SampleCurrent(out info, new float[(joints - 1) * 4], null));
            Throws("bad planner params", Status.InvalidArgument, "max_root_speed is -1", () => {
                var p = PlannerParams.Default();
                p.MaxRootSpeed = -1.0;
                new Planner(model, p);
            });
            Throws("bad path guidance scale", Status.InvalidArgument, "path_guidance_scale is 2, expected (0, 1]",
                   () => planner.SetSampling(0, float.NaN, float.NaN, 2.0f));
            Throws("bad text-only guidance scale", Status.InvalidArgument, "text_only_guidance_scale is 0, expected (0, 4]",
                   () => planner.SetSampling(0, float.NaN, float.NaN, float.NaN, 0.0f));
            // Still usable; the commands that were valid work, including UTF-8 prompts.
            planner.SetPrompt("a person walks forward \u2014 slowly, caf\u00e9");
            planner.AddJointTarget(1.5, "Hand_R", new[] { 0.3, 1.4, 0.2 }, null);
            planner.AddContact(1.0, 2.0, new[] { "Foot_L", model.ContactName(1) }, 1.0);
            ulong id = planner.AddPath(1.0, new[] { 0.0, 0.0, 1.0, 0.0, 1.0, 1.0 }, 1.2, true);
            planner.RemoveConstraint(id);
            planner.SetTargetVelocity(1.0, 0.5);
            planner.ClearTargetVelocity();
            planner.SetSampling(0, float.NaN, float.NaN, 0.5f, 1.5f);
            planner.Advance(0.5);
            planner.Sample(0.25, out info, rotations, positions);
            Check(Math.Abs(info.time - 0.25) < 1e-9 && planner.Time == 0.5, "bad inputs: the planner is usable after the errors");
            Span<float> slice = new float[joints * 3 + 10];
            planner.SampleCurrent(out info, Span<float>.Empty, slice.Slice(5, joints * 3), Span<float>.Empty);
            Check(slice[5] == info.root_position_x && slice[0] == 0.0f, "bad inputs: sampling into a Span slice");
            Check(planner.WaitIdle(60.0), "bad inputs: the commands' windows generated");
            string message;
            Check(!planner.TryPopError(out message), "bad inputs: refused calls queue no worker errors");
        }
    }

    static void TestSamplingAllocations(Model model)
    {
        int joints = model.JointCount;
        var rotations = new float[joints * 4];
        var positions = new float[joints * 3];
        var contacts = new float[model.ContactCount];
        using (var planner = new Planner(model))
        {
            planner.WaitIdle(60.0);
            PoseInfo info;
            string error;
            const int n = 1000;
            for (int i = 0; i < 100; ++i)  // JIT and warm-up
            {
                planner.Advance(0.0);
                planner.SampleCurrent(out info, rotations, positions, contacts);
                planner.TrySampleCurrent(out info, rotations, positions, contacts);
                planner.Sample(0.1, out info, rotations, positions, contacts);
                planner.TryPopError(out error);
            }
            // Mono's GC.GetTotalMemory(false) only moves when a thread takes a new
            // allocation chunk (it reads 0 after a thousand small arrays), so the
            // check uses the exact per-thread counter, GC.GetAllocatedBytesForCurrentThread
            // (in Mono's corlib, not in its reference API: found by reflection), when
            // there is one, and proves it sees a 40-byte array.
            Func<long> allocated = AllocatedBytesCounter();
            if (allocated != null)
            {
                long a0 = allocated();
                var probe = new float[1];
                long a1 = allocated();
                Check(a1 - a0 >= 16 && probe.Length == 1, "sampling: the allocation counter sees a small array (" + (a1 - a0) + " bytes)");
            }
            FullCollect();
            int collections = GC.CollectionCount(0);
            long before = GC.GetTotalMemory(false);
            long threadBefore = allocated != null ? allocated() : 0;
            long t0 = Stopwatch.GetTimestamp();
            for (int i = 0; i < n; ++i)
            {
                planner.Advance(0.001);
                planner.SampleCurrent(out info, rotations, positions, contacts);
            }
            long t1 = Stopwatch.GetTimestamp();
            Span<float> rotationSpan = rotations, positionSpan = positions;
            for (int i = 0; i < n; ++i)
            {
                planner.SampleCurrent(out info, rotationSpan, positionSpan.Slice(0, joints * 3), Span<float>.Empty);
                planner.TrySampleCurrent(out info, rotations, positions, contacts);
                planner.Sample(0.1, out info, rotations, positions, contacts);
                planner.TryPopError(out error);
                if (planner.Time + planner.QueuedSeconds < 0.0) Check(false, "sampling: negative time");
            }
            long threadBytes = allocated != null ? allocated() - threadBefore : 0;
            long after = GC.GetTotalMemory(false);
            int collected = GC.CollectionCount(0) - collections;
            Info("managed heap " + before + " -> " + after + " bytes (GC.GetTotalMemory), this thread allocated " +
                 (allocated != null ? threadBytes + " bytes" : "? (no per-thread counter)") + ", " + collected +
                 " collections over " + n + " frames");
            Check(threadBytes == 0 && after - before == 0 && collected == 0,
                  "sampling: " + threadBytes + " managed bytes allocated over " + n + " frames of advance + sample (+ " +
                  n + " of span sample, try-sample, sample-at, pop-error poll)");
            Console.WriteLine("bench: csharp advance+sample_current (21 joints, idle planner) " +
                              ((t1 - t0) * 1e6 / Stopwatch.Frequency / n).ToString("F2") + " us/frame");
        }
    }

    static Func<long> AllocatedBytesCounter()
    {
        var method = typeof(GC).GetMethod("GetAllocatedBytesForCurrentThread",
                                          System.Reflection.BindingFlags.Static | System.Reflection.BindingFlags.Public |
                                          System.Reflection.BindingFlags.NonPublic, null, Type.EmptyTypes, null);
        if (method == null || method.ReturnType != typeof(long)) return null;
        return (Func<long>)Delegate.CreateDelegate(typeof(Func<long>), method);
    }

    static void TestDisposeMidWindow(Model model)
    {
        var planner = new Planner(model);
        planner.SetPrompt("a person runs in a circle");
        bool inFlight = WaitInFlight(planner);
        var watch = Stopwatch.StartNew();
        planner.Dispose();  // the first window is in flight: cancelled, the worker joined
        Info("disposed with a window in flight (" + inFlight + ") in " + watch.Elapsed.TotalMilliseconds.ToString("F1") + " ms");
        Check(inFlight && planner.IsDisposed && watch.Elapsed.TotalSeconds < 10,
              "dispose mid-window: returns with the window in flight cancelled (" + watch.Elapsed.TotalMilliseconds.ToString("F1") + " ms)");
        planner.Dispose();  // twice: a no-op
        try { planner.Advance(0.1); Check(false, "dispose mid-window: a disposed planner still answered"); }
        catch (ObjectDisposedException) { Check(true, "dispose mid-window: calls on a disposed planner throw ObjectDisposedException"); }

        // Another, after playing a while and with commands queued.
        planner = new Planner(model);
        planner.WaitIdle(60.0);
        planner.Advance(0.8);
        planner.SetPrompt("wave with the right hand");
        planner.AddWaypoint(3.0, 1.0, 2.0);
        inFlight = WaitInFlight(planner);
        planner.Dispose();
        Check(inFlight && planner.IsDisposed, "dispose mid-window: a playing planner with a splice in flight");

        // Disposed on one thread while another samples it: the SafeHandle holds the free
        // back until the call in progress returns; the sampler then gets ObjectDisposedException.
        planner = new Planner(model);
        planner.WaitIdle(60.0);
        var positions = new float[planner.JointCount * 3];
        long sampled = 0;
        Exception stray = null;
        bool sawDisposed = false;
        var sampler = new Thread(() => {
            try
            {
                PoseInfo info;
                while (true)
                {
                    planner.Advance(0.0001);
                    planner.SampleCurrent(out info, null, positions);
                    ++sampled;
                }
            }
            catch (ObjectDisposedException) { sawDisposed = true; }
            catch (Exception e) { stray = e; }
        });
        sampler.Start();
        while (Interlocked.Read(ref sampled) < 1000) Thread.Sleep(1);
        planner.SetPrompt("a person jumps");
        planner.Dispose();
        bool joined = sampler.Join(10000);
        Check(joined && sawDisposed && stray == null, "dispose mid-window: while another thread samples (" + sampled +
              " samples, then ObjectDisposedException" + (stray == null ? "" : "; " + stray.GetType().Name + ": " + stray.Message) + ")");
    }

    // Polls the stats until a window is being generated (true), at most 2 s.
    static bool WaitInFlight(Planner planner)
    {
        var watch = Stopwatch.StartNew();
        while (watch.Elapsed.TotalSeconds < 2.0)
        {
            if (planner.GetStats().window_in_flight) return true;
            Thread.Sleep(0);
        }
        return false;
    }

    static void TestBatcher(Model model)
    {
        var bp = BatcherParams.Default();
        bp.MaxWindows = 0;
        Throws("bad batcher params", Status.InvalidArgument, "max_windows is 0", () => new Batcher(bp));
        bp.MaxWindows = 2;
        bp.GatherSeconds = 10.0;  // the batch starts when both windows are there
        var batcher = new Batcher(bp);
        var pp = PlannerParams.Default();
        pp.Batcher = batcher;
        var a = new Planner(model, pp);
        var b = new Planner(model, pp);
        Check(a.WaitIdle(60.0) && b.WaitIdle(60.0), "batcher: two planners' first windows");
        BatcherStats stats = batcher.GetStats();
        Check(stats.batches == 1 && stats.windows == 2 && stats.largest_batch == 2,
              "batcher: one batch of 2 windows (" + stats.batches + " batches, " + stats.windows + " windows)");
        // Worker errors are polled: the batcher freed first, the next window fails.
        batcher.Dispose();
        a.SetPrompt("a person walks");
        a.WaitIdle(60.0);
        string message;
        bool popped = a.TryPopError(out message);
        Check(popped && message.Contains("the window batcher is gone"), "batcher: worker error popped: \"" + message + "\"");
        Check(!a.TryPopError(out message), "batcher: the error queue is empty after the pop");
        a.Dispose();
        b.Dispose();
    }

    // 200 planners created and disposed: resident memory grows by less than a few MB.
    static void TestResidentGrowth(Model model)
    {
        for (int i = 0; i < 20; ++i) new Planner(model).Dispose();  // warm-up: thread stacks, arenas, JIT
        FullCollect();
        long before = ResidentBytes();
        var watch = Stopwatch.StartNew();
        int cancelled = 0;
        for (int i = 0; i < 200; ++i)
        {
            var planner = new Planner(model);
            if (i % 2 == 1) planner.SetPrompt("a person walks");
            if (WaitInFlight(planner)) ++cancelled;  // disposed mid-window
            planner.Dispose();
        }
        FullCollect();
        long growth = ResidentBytes() - before;
        Info("200 create/dispose cycles in " + watch.ElapsedMilliseconds + " ms: resident " + before / 1024 + " KiB -> " +
             (before + growth) / 1024 + " KiB (" + (growth / 1024.0 / 1024.0).ToString("F2") + " MiB growth), " + cancelled +
             " disposed with a window in flight");
        Check(growth < 4L * 1024 * 1024, "resident growth over 200 create/dispose cycles " +
              (growth / 1024.0 / 1024.0).ToString("F2") + " MiB (under 4 MiB)");
    }

    [MethodImpl(MethodImplOptions.NoInlining)]
    static WeakReference[] Abandon(Model model, int count)
    {
        var refs = new WeakReference[count];
        for (int i = 0; i < count; ++i) refs[i] = new WeakReference(new Planner(model));
        return refs;
    }

    // 200 planners never disposed: the finalizers free them (no crash, no leak).
    static void TestFinalizers(Model model)
    {
        // Warm-up: ten planners alive at once take the process's malloc arenas and ONNX
        // Runtime buffers to their working size (it levels off after two or three rounds).
        for (int round = 0; round < 3; ++round) { Abandon(model, 10); FullCollect(); }
        FullCollect();
        long before = ResidentBytes();
        int alive = 0;
        var watch = Stopwatch.StartNew();
        for (int round = 0; round < 20; ++round)
        {
            WeakReference[] refs = Abandon(model, 10);
            FullCollect();
            foreach (var r in refs) if (r.IsAlive) ++alive;
        }
        FullCollect();
        long growth = ResidentBytes() - before;
        Info("200 planners finalized without Dispose in " + watch.ElapsedMilliseconds + " ms: resident growth " +
             (growth / 1024.0 / 1024.0).ToString("F2") + " MiB, " + alive + " still alive after collection");
        Check(alive == 0, "finalizers: 200 abandoned planners collected");
        Check(growth < 8L * 1024 * 1024, "finalizers: resident growth " + (growth / 1024.0 / 1024.0).ToString("F2") + " MiB (under 8 MiB)");
        // A planner that outlives its (finalized) Model object's handle: the library keeps the package.
        Model own = Model.LoadFromFolder(modelFolder);
        var planner = new Planner(own);
        own.Dispose();
        Check(planner.WaitIdle(60.0), "finalizers: a planner outlives its disposed model");
        PoseInfo info;
        planner.SampleCurrent(out info, null, new float[planner.JointCount * 3]);
        Check(info.window_id >= 1, "finalizers: and samples (window " + info.window_id + ")");
        planner.Dispose();
        // Only the planner is kept: its Model is not finalized under it.
        planner = PlannerOfUnreferencedModel();
        FullCollect();
        Check(!planner.Model.IsDisposed && planner.WaitIdle(60.0) && planner.Model.JointIndex("Hand_R") == 12,
              "finalizers: a planner keeps its Model alive through collections");
        planner.Dispose();
    }

    [MethodImpl(MethodImplOptions.NoInlining)]
    static Planner PlannerOfUnreferencedModel()
    {
        return new Planner(Model.LoadFromFolder(modelFolder));
    }

    static void TestLoadFromMemory()
    {
        var files = new List<ModelFile>();
        foreach (string name in new[] { "model.json", "history.onnx", "goals.onnx", "denoiser.onnx", "decoder.onnx", "encoder.onnx", "text_encoder.onnx", "vocab.txt" })
            files.Add(new ModelFile(name, File.ReadAllBytes(Path.Combine(modelFolder, name))));
        using (Model model = Model.LoadFromMemory(files, "default (memory)"))
            Check(model.JointCount == 21 && model.JointName(12) == "Hand_R", "load from memory: the shipped model's files as bytes");
    }
}
