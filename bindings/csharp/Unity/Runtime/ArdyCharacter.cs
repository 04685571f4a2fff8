// ArdyCharacter: drives a humanoid Animator's bones with an ARDY planner.
// An integration example, never compiled against UnityEngine by this project
// (see ../README.md). It needs the bindings (Runtime/Ardy/*.cs, copied from
// bindings/csharp/Ardy by scripts/package_native.sh) and the native libraries
// in Plugins/x86_64/.
//
// Coordinates. The model's world is right-handed, Y up, heading 0 faces +Z, so
// the character's left is +X (its joints *_L sit at +X). Unity is left-handed,
// Y up, +Z forward, +X right. Mirroring the X axis, M = diag(-1, 1, 1), maps one
// onto the other and keeps left on the character's left:
//   position  (x, y, z)      -> (-x, y, z)
//   rotation  R              -> M R M       (a reflection conjugates rotations)
//   quaternion (x, y, z, w)  -> (x, -y, -z, w)
// because a rotation by angle a about axis u becomes, under a reflection, the
// rotation by -a about M u: (sin(a/2) u, cos(a/2)) -> (-sin(a/2) M u, cos(a/2)),
// and -M u = (ux, -uy, -uz). Conjugation respects products, so parent-relative
// rotations may be converted one by one and multiplied in Unity afterwards.
// (The (-x, -y, z, w) rule quoted elsewhere is the one for mirroring Z.)
//
// Retargeting. The model's rest pose is a T-pose with every joint at identity
// (model.json "skeleton": arms along +-X, legs down, toes +Z). The rig must be in
// its T-pose, facing this GameObject's +Z, when the component starts: each bone's
// rotation then (relative to this transform) is its bind rotation B, and a
// sampled world rotation W (converted) is applied as
//   bone.rotation = origin.rotation * W * B.
// The model's world origin is this GameObject's pose at start.
using System;
using UnityEngine;

namespace Ardy
{
    [DisallowMultipleComponent]
    public sealed class ArdyCharacter : MonoBehaviour
    {
        [Tooltip("The humanoid Animator whose bones are driven (default: the one on this GameObject or below). " +
                 "Give it no controller, or the controller's pose is overwritten each LateUpdate.")]
        public Animator animator;

        [Tooltip("The model package folder, relative to StreamingAssets (or an absolute path).")]
        public string modelFolder = "ArdyModels/default";

        [Tooltip("The prompt at start; SetPrompt changes it later.")]
        public string prompt = "a person walks forward";

        [Tooltip("Moves this GameObject to the root's ground projection each frame (the hips follow in world space either way).")]
        public bool moveRoot = true;

        [Tooltip("Scales the model's metres (1: a rig of the model's size, hips about 0.95 m up).")]
        public float positionScale = 1f;

        [Tooltip("ONNX Runtime threads per graph call; 0: all cores but one.")]
        public int intraOpThreads = 0;

        // The model's joints (model.json "skeleton"/"joints") and Unity's humanoid bones.
        static readonly string[] JointNames = {
            "Hips", "Spine", "Chest", "Neck", "Head",
            "Shoulder_L", "UpperArm_L", "LowerArm_L", "Hand_L",
            "Shoulder_R", "UpperArm_R", "LowerArm_R", "Hand_R",
            "UpperLeg_L", "LowerLeg_L", "Foot_L", "Toes_L",
            "UpperLeg_R", "LowerLeg_R", "Foot_R", "Toes_R" };
        static readonly HumanBodyBones[] Bones = {
            HumanBodyBones.Hips, HumanBodyBones.Spine, HumanBodyBones.Chest, HumanBodyBones.Neck, HumanBodyBones.Head,
            HumanBodyBones.LeftShoulder, HumanBodyBones.LeftUpperArm, HumanBodyBones.LeftLowerArm, HumanBodyBones.LeftHand,
            HumanBodyBones.RightShoulder, HumanBodyBones.RightUpperArm, HumanBodyBones.RightLowerArm, HumanBodyBones.RightHand,
            HumanBodyBones.LeftUpperLeg, HumanBodyBones.LeftLowerLeg, HumanBodyBones.LeftFoot, HumanBodyBones.LeftToes,
            HumanBodyBones.RightUpperLeg, HumanBodyBones.RightLowerLeg, HumanBodyBones.RightFoot, HumanBodyBones.RightToes };

        Model _model;
        Planner _planner;
        int _joints;
        int _hips;
        int[] _parents;
        Transform[] _bones;   // by model joint; null where the rig has no such bone
        Quaternion[] _bind;   // bone rotation relative to this transform at start (T-pose)
        Quaternion[] _world;  // sampled world rotations, converted, this frame
        float[] _rotations;   // xyzw per joint, parent-relative (root: world)
        float[] _positions;   // xyz per joint, world
        Vector3 _originPosition;
        Quaternion _originRotation;

        /// <summary>The planner (null before Start or after a failed load), for the rest of the
        /// API: AddPath, AddJointTarget, SetTargetVelocity, GetStats, ...</summary>
        public Planner Planner { get { return _planner; } }

        void Start()
        {
            if (animator == null) animator = GetComponentInChildren<Animator>();
            if (animator == null || !animator.isHuman)
            {
                Debug.LogError("ArdyCharacter: needs a humanoid Animator", this);
                enabled = false;
                return;
            }
            string folder = System.IO.Path.IsPathRooted(modelFolder)
                ? modelFolder : System.IO.Path.Combine(Application.streamingAssetsPath, modelFolder);
            try
            {
                Library.CheckAbi();
                ModelParams mp = ModelParams.Default();
                mp.IntraOpThreads = intraOpThreads;
                _model = Model.LoadFromFolder(folder, mp);
                _planner = new Planner(_model);
                if (!string.IsNullOrEmpty(prompt)) _planner.SetPrompt(prompt);
            }
            catch (Exception e)  // ArdyException (a bad folder, ...) or DllNotFoundException (Plugins/)
            {
                Debug.LogError("ArdyCharacter: " + e.Message, this);
                Release();
                enabled = false;
                return;
            }
            _joints = _model.JointCount;
            _hips = 0;
            _parents = new int[_joints];
            _bones = new Transform[_joints];
            _bind = new Quaternion[_joints];
            _world = new Quaternion[_joints];
            _rotations = new float[_joints * 4];
            _positions = new float[_joints * 3];
            _originPosition = transform.position;
            _originRotation = transform.rotation;
            Quaternion toLocal = Quaternion.Inverse(_originRotation);
            for (int j = 0; j < _joints; j++)
            {
                _parents[j] = _model.JointParent(j);
                int k = Array.IndexOf(JointNames, _model.JointName(j));
                if (k < 0) continue;  // a joint this component does not know: left alone
                _bones[j] = animator.GetBoneTransform(Bones[k]);  // null for optional bones the rig lacks
                if (_bones[j] != null) _bind[j] = toLocal * _bones[j].rotation;
            }
        }

        // After the Animator (Update), so that the sampled pose is the one rendered.
        // Allocates nothing unless the worker reported an error.
        void LateUpdate()
        {
            if (_planner == null) return;
            string error;
            while (_planner.TryPopError(out error)) Debug.LogWarning("ArdyCharacter: " + error, this);
            _planner.Advance(Time.deltaTime);
            PoseInfo info;
            if (_planner.TrySampleCurrent(out info, _rotations, _positions) != Status.Ok) return;  // NotReady at first

            // Rotations: parents come before their children in the model's joint order.
            for (int j = 0; j < _joints; j++)
            {
                int r = 4 * j;
                var local = new Quaternion(_rotations[r], -_rotations[r + 1], -_rotations[r + 2], _rotations[r + 3]);
                int p = _parents[j];
                _world[j] = p < 0 ? local : _world[p] * local;
                if (_bones[j] != null) _bones[j].rotation = _originRotation * _world[j] * _bind[j];
            }

            // The root: this GameObject on the ground under the hips, the hips where sampled.
            int h = 3 * _hips;
            var hips = new Vector3(-_positions[h], _positions[h + 1], _positions[h + 2]) * positionScale;
            if (moveRoot) transform.position = _originPosition + _originRotation * new Vector3(hips.x, 0f, hips.z);
            if (_bones[_hips] != null) _bones[_hips].position = _originPosition + _originRotation * hips;
        }

        /// <summary>The prompt from the replan buffer on; null or "" clears it.</summary>
        public void SetPrompt(string text)
        {
            prompt = text;
            if (_planner != null) _planner.SetPrompt(string.IsNullOrEmpty(text) ? null : text);
        }

        /// <summary>The root at a Unity world point (its ground projection) at planner time
        /// seconds (Planner.Time is now); returns the constraint's id (0 before Start).</summary>
        public ulong AddWaypoint(double time, Vector3 worldPoint)
        {
            if (_planner == null) return 0;
            Vector3 local = Quaternion.Inverse(_originRotation) * (worldPoint - _originPosition) / positionScale;
            return _planner.AddWaypoint(time, -local.x, local.z);  // mirror X back into the model's world
        }

        /// <summary>The root at a Unity world point, seconds from now.</summary>
        public ulong AddWaypointIn(double seconds, Vector3 worldPoint)
        {
            return _planner == null ? 0 : AddWaypoint(_planner.Time + seconds, worldPoint);
        }

        void OnDestroy() { Release(); }

        void Release()
        {
            if (_planner != null) { _planner.Dispose(); _planner = null; }
            if (_model != null) { _model.Dispose(); _model = null; }
        }
    }
}
