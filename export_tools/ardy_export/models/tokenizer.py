"""Body tokenizer: a causal transformer FSQ autoencoder over patches of P frames.

Encoder: normalized body features [B, N, 253] (N = T * P) -> patches [B, T, P * 253] ->
linear -> sinusoidal positions -> causal transformer -> linear to L -> FSQ codes [B, T, L]
(raw codes in [-1, 1]; the denoiser's latent normalization is applied outside, see
``graphs.py``).

Decoder: codes [B, T, L] plus the root of the token's P frames -> causal transformer ->
normalized body features [B, N, 253]. The root enters in its LOCAL form, computed inside
the decoder from the normalized global root (``root_input = "local"``, the paper's design):
per frame (heading rate, x and z velocity in the character's heading frame, height), from
the frame and the one before it. The frame before the first one is ``prev_root``; when
``prev_root_valid`` is 0 the first frame copies the second frame's rates (a forward
difference, like the features' first-frame velocities). ``root_input = "global"`` feeds the
normalized global root instead (the ablation of issue 5).

Attention is causal at token level: token t sees tokens 0..t of the same call, so changing a
later frame never changes an earlier token's code or decoded frames. The optional seam parts
are causal too: the seam filter (``seam_filter_frames``) blends a frame with the frames before
it only, the overlap (``seam_overlap_frames``) has token t also decode the first frames of
token t + 1's patch, cross-faded into that patch's own.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, replace
from typing import Any

import torch
import torch.nn.functional as F
from torch import Tensor, nn

from ardy_export.models import layout as L
from ardy_export.models.fsq import FSQ
from ardy_export.models.layers import TransformerStack, attention_bias, sinusoidal_encoding

LOCAL_ROOT_DIM = 4


@dataclass
class TokenizerConfig:
    body_dim: int = 253
    root_dim: int = 5
    patch: int = 4
    fps: float = 20.0
    latent_dim: int = 32
    # Levels per latent dimension: one int for all dimensions, or a list of latent_dim ints.
    fsq_levels: int | list[int] = 16
    width: int = 256
    layers: int = 4
    heads: int = 4
    ff_mult: int = 4
    root_input: str = "local"  # "local" (paper) or "global" (ablation)
    # Frames of a causal per-feature filter over the decoded frames (0: none): each frame
    # may blend with the frames before it, across the seam to the previous patch, which a
    # patch decoded from its own token alone leaves as a step.
    seam_filter_frames: int = 0
    # Frames of the next patch every token also decodes (0: none), cross-faded into that
    # patch's own first frames: the motion crosses the seam on one token's prediction.
    seam_overlap_frames: int = 0
    # Whether the foot contact channels are cross-faded too (False: a patch's contacts are
    # its own; blended flags mislead the runtime's foot lock where a foot plants or lifts).
    seam_overlap_contacts: bool = True
    extra: dict[str, Any] = field(default_factory=dict)

    def levels(self) -> list[int]:
        if isinstance(self.fsq_levels, int):
            return [self.fsq_levels] * self.latent_dim
        if len(self.fsq_levels) != self.latent_dim:
            raise ValueError(
                f"tokenizer: fsq_levels has {len(self.fsq_levels)} entries, "
                f"latent_dim is {self.latent_dim}"
            )
        return list(self.fsq_levels)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    def without_seam_parts(self) -> TokenizerConfig:
        """This config with the decoder's seam parts at their defaults (none): what a decoder
        fine-tune may change and the latent codes do not depend on."""
        defaults = TokenizerConfig()
        return replace(
            self,
            seam_filter_frames=defaults.seam_filter_frames,
            seam_overlap_frames=defaults.seam_overlap_frames,
            seam_overlap_contacts=defaults.seam_overlap_contacts,
        )

    @classmethod
    def from_dict(cls, values: dict[str, Any]) -> TokenizerConfig:
        known = {k: v for k, v in values.items() if k in cls.__dataclass_fields__}
        return cls(**known)


def safe_atan2(y: Tensor, x: Tensor) -> Tensor:
    """atan2 as ``2 atan(y / (r + x))`` (ONNX has Atan, not Atan2); exact away from +-pi."""
    r = torch.sqrt(x * x + y * y)
    return 2.0 * torch.atan(y / (r + x + 1e-12))


def local_root(root: Tensor, prev_root: Tensor, prev_valid: Tensor, fps: float) -> Tensor:
    """Local root per frame from the raw (un-normalized) global root.

    root [B, N, 5] (x, y, z, cos psi, sin psi), prev_root [B, 5], prev_valid [B] (0 or 1)
    -> [B, N, 4] = (heading rate rad/s, x velocity, z velocity (m/s, in the heading frame of
    the frame itself: x right... z forward), height m).
    """
    prev = torch.cat((prev_root.unsqueeze(1), root[:, :-1]), dim=1)
    c = root[..., 3]
    s = root[..., 4]
    norm = torch.sqrt(c * c + s * s) + 1e-8
    c = c / norm
    s = s / norm
    cp = prev[..., 3]
    sp = prev[..., 4]
    normp = torch.sqrt(cp * cp + sp * sp) + 1e-8
    cp = cp / normp
    sp = sp / normp
    dpsi = safe_atan2(s * cp - c * sp, c * cp + s * sp) * fps
    dx = (root[..., 0] - prev[..., 0]) * fps
    dz = (root[..., 2] - prev[..., 2]) * fps
    vx = c * dx - s * dz
    vz = s * dx + c * dz
    rates = torch.stack((dpsi, vx, vz), dim=-1)  # [B, N, 3]
    if rates.shape[1] > 1:
        valid = prev_valid.to(rates.dtype)[:, None]
        first = valid * rates[:, 0] + (1.0 - valid) * rates[:, 1]
        rates = torch.cat((first.unsqueeze(1), rates[:, 1:]), dim=1)
    else:
        rates = rates * prev_valid.to(rates.dtype)[:, None, None]
    return torch.cat((rates, root[..., 1:2]), dim=-1)


def seam_filter(features: int, frames: int) -> nn.Conv1d:
    """A causal filter of ``frames`` taps per feature that starts as the identity (the last
    tap, the frame itself, 1; the earlier ones 0)."""
    conv = nn.Conv1d(features, features, frames, groups=features, bias=False)
    with torch.no_grad():
        conv.weight.zero_()
        conv.weight[:, 0, -1] = 1.0
    return conv


def causal_bias(tokens: int, batch: int, device: torch.device) -> Tensor:
    idx = torch.arange(tokens, device=device)
    allowed = (idx[None, :] <= idx[:, None]).unsqueeze(0).expand(batch, tokens, tokens)
    return attention_bias(allowed)


# The tokenizer's two halves, by module name: the encoder (encoder.onnx; its codes are what a
# denoiser learns) and the decoder (decoder.onnx).
# The decoder's optional seam parts (None when absent).
SEAM_MODULES = ("dec_overlap", "seam_filter")
TOKENIZER_PARTS = {
    "encoder": ("enc_in", "encoder", "enc_out"),
    "decoder": ("dec_in", "decoder", "dec_out", *SEAM_MODULES),
}


class BodyTokenizer(nn.Module):
    def __init__(self, config: TokenizerConfig) -> None:
        super().__init__()
        self.config = config
        c = config
        if c.root_input not in ("local", "global"):
            raise ValueError(
                f"tokenizer: root_input must be 'local' or 'global', got {c.root_input!r}"
            )
        ff = c.width * c.ff_mult
        self.fsq = FSQ(c.levels())
        self.enc_in = nn.Linear(c.patch * c.body_dim, c.width)
        self.encoder = TransformerStack(c.width, c.layers, c.heads, ff)
        self.enc_out = nn.Linear(c.width, c.latent_dim)
        root_features = LOCAL_ROOT_DIM if c.root_input == "local" else c.root_dim
        self.dec_in = nn.Linear(c.latent_dim + c.patch * root_features, c.width)
        self.decoder = TransformerStack(c.width, c.layers, c.heads, ff)
        self.dec_out = nn.Linear(c.width, c.patch * c.body_dim)
        if c.seam_filter_frames < 0:
            raise ValueError(
                f"tokenizer: seam_filter_frames is {c.seam_filter_frames}, expected >= 0"
            )
        if not 0 <= c.seam_overlap_frames <= c.patch:
            raise ValueError(
                f"tokenizer: seam_overlap_frames is {c.seam_overlap_frames}, expected 0.."
                f"{c.patch} (the patch)"
            )
        self.dec_overlap = (
            nn.Linear(c.width, c.seam_overlap_frames * c.body_dim)
            if c.seam_overlap_frames > 0
            else None
        )
        self.seam_filter = (
            seam_filter(c.body_dim, c.seam_filter_frames) if c.seam_filter_frames > 0 else None
        )
        # Statistics (set from the data before training, saved in the state dict): the
        # feature normalization of the root, and of the local root fed to the decoder.
        self.register_buffer("root_mean", torch.zeros(c.root_dim))
        self.register_buffer("root_std", torch.ones(c.root_dim))
        self.register_buffer("local_mean", torch.zeros(LOCAL_ROOT_DIM))
        self.register_buffer("local_std", torch.ones(LOCAL_ROOT_DIM))

    @property
    def latent_dim(self) -> int:
        return self.config.latent_dim

    def set_statistics(
        self, root_mean: Tensor, root_std: Tensor, local_mean: Tensor, local_std: Tensor
    ) -> None:
        self.root_mean.copy_(root_mean)
        self.root_std.copy_(root_std)
        self.local_mean.copy_(local_mean)
        self.local_std.copy_(local_std)

    def _positions(self, tokens: int, device: torch.device) -> Tensor:
        return sinusoidal_encoding(torch.arange(tokens, device=device), self.config.width)

    def encode_continuous(self, body: Tensor) -> Tensor:
        """Pre-quantization encoder output [B, T, L]."""
        batch, frames, dim = body.shape
        p = self.config.patch
        tokens = frames // p
        x = self.enc_in(body.reshape(batch, tokens, p * dim))
        x = x + self._positions(tokens, body.device)
        x = self.encoder(x, causal_bias(tokens, batch, body.device))
        return self.enc_out(x)

    def encode(self, body: Tensor) -> Tensor:
        """Normalized body [B, T * P, body_dim] -> FSQ codes [B, T, L]."""
        return self.fsq(self.encode_continuous(body))

    def root_condition(self, root: Tensor, prev_root: Tensor, prev_valid: Tensor) -> Tensor:
        """Per-frame decoder root input [B, N, 4 or 5] from the normalized global root."""
        if self.config.root_input == "global":
            return root
        raw = root * self.root_std + self.root_mean
        raw_prev = prev_root * self.root_std + self.root_mean
        local = local_root(raw, raw_prev, prev_valid, self.config.fps)
        return (local - self.local_mean) / self.local_std

    def decode(self, codes: Tensor, root: Tensor, prev_root: Tensor, prev_valid: Tensor) -> Tensor:
        """codes [B, T, L], normalized root [B, T * P, 5], prev_root [B, 5] (normalized),
        prev_valid [B] -> normalized body [B, T * P, body_dim]."""
        batch, tokens, _ = codes.shape
        p = self.config.patch
        cond = self.root_condition(root, prev_root, prev_valid).reshape(batch, tokens, -1)
        x = self.dec_in(torch.cat((codes, cond), dim=-1))
        x = x + self._positions(tokens, codes.device)
        x = self.decoder(x, causal_bias(tokens, batch, codes.device))
        body = self.dec_out(x).reshape(batch, tokens * p, self.config.body_dim)
        if self.dec_overlap is not None:
            body = self._cross_fade(body, self.dec_overlap(x))
        if self.seam_filter is None:
            return body
        # The first frames repeat frame 0 (the runtime decodes after context tokens, so
        # the frames it keeps always have real frames before them).
        padded = F.pad(body.transpose(1, 2), (self.config.seam_filter_frames - 1, 0), "replicate")
        return self.seam_filter(padded).transpose(1, 2)

    def _cross_fade(self, body: Tensor, overlap: Tensor) -> Tensor:
        """body [B, T * P, D] with the first O frames of every patch but the call's first
        cross-faded from the previous token's overlap [B, T, O * D] (its weight falling
        linearly from O / (O + 1) at the seam) into the patch's own frames."""
        c = self.config
        batch, frames, dim = body.shape
        tokens, o = frames // c.patch, c.seam_overlap_frames
        patches = body.reshape(batch, tokens, c.patch, dim)
        carried = overlap.reshape(batch, tokens, o, dim)[:, :-1]
        if not c.seam_overlap_contacts:
            carried_part = torch.ones(dim, dtype=body.dtype, device=body.device)
            carried_part[L.CONTACT_SLICE.start - c.root_dim : L.CONTACT_SLICE.stop - c.root_dim] = 0
            carried = carried * carried_part + patches[:, 1:, :o] * (1.0 - carried_part)
        own = torch.arange(1, o + 1, dtype=body.dtype, device=body.device) / (o + 1)
        own = own.reshape(1, 1, o, 1)
        heads = own * patches[:, 1:, :o] + (1.0 - own) * carried
        later = torch.cat((heads, patches[:, 1:, o:]), dim=2)
        return torch.cat((patches[:, :1], later), dim=1).reshape(batch, frames, dim)

    def with_seam_parts(
        self, filter_frames: int = 0, overlap_frames: int = 0, overlap_contacts: bool = True
    ) -> BodyTokenizer:
        """A copy with the seam parts it lacks added: a seam filter of ``filter_frames``
        frames that starts as the identity, an overlap of ``overlap_frames`` frames that
        starts by holding the previous patch's last frame (so until trained the seams are
        blended toward it; ``overlap_contacts``: its contact channels too). Everything else
        is this tokenizer's."""
        c = self.config
        changes: dict[str, Any] = {}
        if filter_frames and not c.seam_filter_frames:
            changes["seam_filter_frames"] = filter_frames
        if overlap_frames and not c.seam_overlap_frames:
            changes["seam_overlap_frames"] = overlap_frames
            changes["seam_overlap_contacts"] = overlap_contacts
        grown = BodyTokenizer(replace(c, **changes))
        missing, unexpected = grown.load_state_dict(self.state_dict(), strict=False)
        if unexpected or any(
            not key.startswith(tuple(module + "." for module in SEAM_MODULES)) for key in missing
        ):
            raise ValueError(f"tokenizer: cannot add seam parts ({missing}, {unexpected})")
        if "seam_overlap_frames" in changes:
            last = slice((c.patch - 1) * c.body_dim, c.patch * c.body_dim)
            with torch.no_grad():
                grown.dec_overlap.weight.copy_(self.dec_out.weight[last].repeat(overlap_frames, 1))
                grown.dec_overlap.bias.copy_(self.dec_out.bias[last].repeat(overlap_frames))
        return grown

    def forward(
        self, body: Tensor, root: Tensor, prev_root: Tensor, prev_valid: Tensor
    ) -> tuple[Tensor, Tensor]:
        """Reconstruction: returns (normalized body [B, N, body_dim], codes [B, T, L])."""
        codes = self.encode(body)
        return self.decode(codes, root, prev_root, prev_valid), codes
