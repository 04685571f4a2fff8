"""Body tokenizer: FSQ rounding and straight-through gradient, shapes, causality, local root."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from ardy_export.models import layout as L
from ardy_export.models.fsq import FSQ
from ardy_export.models.graphs import DecoderGraph, EncoderGraph
from ardy_export.models.tokenizer import BodyTokenizer, TokenizerConfig, local_root, safe_atan2
from ardy_export.training.synthetic import synthetic_clip

torch.set_num_threads(1)


def _tokenizer(root_input: str = "local", seed: int = 0) -> BodyTokenizer:
    torch.manual_seed(seed)
    cfg = TokenizerConfig(
        body_dim=L.BODY_DIM,
        latent_dim=6,
        fsq_levels=[3, 4, 5, 8, 8, 16],
        width=32,
        layers=2,
        heads=2,
        ff_mult=2,
        root_input=root_input,
    )
    return BodyTokenizer(cfg).eval()


@pytest.mark.parametrize("levels", [[3], [4], [5], [8], [16], [64]])
def test_fsq_codes_lie_on_the_level_grid(levels: list[int]) -> None:
    fsq = FSQ(levels * 3)
    z = torch.linspace(-20, 20, 4001)[:, None].expand(-1, 3)
    codes = fsq(z)
    idx = fsq.codes_to_indices(codes)
    n = levels[0]
    assert idx.min() == 0 and idx.max() == n - 1  # every level reachable, no more
    assert len(torch.unique(idx[:, 0])) == n
    half = n // 2
    assert torch.allclose(codes * half, torch.round(codes * half), atol=1e-6)
    assert codes.min() >= -1.0 and codes.max() <= 1.0


def test_fsq_straight_through_gradient() -> None:
    fsq = FSQ([8, 5])
    z = torch.randn(64, 2, requires_grad=True)
    fsq(z).sum().backward()
    zz = z.detach().clone().requires_grad_(True)
    (fsq.bound(zz) / fsq.half_width).sum().backward()
    assert z.grad is not None and zz.grad is not None
    assert torch.allclose(z.grad, zz.grad)  # the rounding passes the gradient unchanged
    assert (z.grad > 0).all()


def test_tokenizer_shapes_and_graph_wrappers() -> None:
    tok = _tokenizer()
    b, t, p = 3, 5, 4
    body = torch.randn(b, t * p, L.BODY_DIM)
    root = torch.randn(b, t * p, 5)
    codes = tok.encode(body)
    assert codes.shape == (b, t, 6)
    out = tok.decode(codes, root, torch.randn(b, 5), torch.tensor([1.0, 0.0, 1.0]))
    assert out.shape == (b, t * p, L.BODY_DIM)
    lm, ls = torch.randn(6), torch.rand(6) + 0.5
    enc = EncoderGraph(tok, lm, ls)
    dec = DecoderGraph(tok, lm, ls)
    latent = enc(body)
    assert torch.allclose(latent * ls + lm, codes, atol=1e-5)
    tokens = torch.cat((root.reshape(b, t, p * 5), latent), dim=-1)
    prev, valid = torch.randn(b, 5), torch.ones(b)
    assert torch.allclose(dec(tokens, prev, valid), tok.decode(codes, root, prev, valid), atol=1e-5)


@pytest.mark.parametrize("root_input", ["local", "global"])
def test_tokenizer_is_causal(root_input: str) -> None:
    """Changing frames of later tokens changes no earlier token's code or decoded frame."""
    tok = _tokenizer(root_input)
    p, t, k = 4, 6, 3
    g = torch.Generator().manual_seed(1)
    body = torch.randn(2, t * p, L.BODY_DIM, generator=g)
    root = torch.randn(2, t * p, 5, generator=g)
    prev, valid = torch.randn(2, 5, generator=g), torch.tensor([1.0, 0.0])
    body2, root2 = body.clone(), root.clone()
    body2[:, k * p :] += 3.0 * torch.randn(2, (t - k) * p, L.BODY_DIM, generator=g)
    root2[:, k * p :] += 3.0 * torch.randn(2, (t - k) * p, 5, generator=g)
    with torch.no_grad():
        c1, c2 = tok.encode_continuous(body), tok.encode_continuous(body2)
        assert torch.allclose(c1[:, :k], c2[:, :k], atol=1e-5)
        assert not torch.allclose(c1[:, k:], c2[:, k:], atol=1e-3)
        q1, q2 = tok.encode(body), tok.encode(body2)
        assert torch.equal(q1[:, :k], q2[:, :k])
        d1 = tok.decode(q1, root, prev, valid)
        d2 = tok.decode(q2, root2, prev, valid)
        assert torch.allclose(d1[:, : k * p], d2[:, : k * p], atol=1e-5)
        assert not torch.allclose(d1[:, k * p :], d2[:, k * p :], atol=1e-3)


def test_seam_filter_starts_as_the_identity_and_stays_causal() -> None:
    """A tokenizer grown with a seam filter decodes what it decoded before; once the filter
    blends frames, a frame still depends on no later token."""
    tok = _tokenizer()
    grown = tok.with_seam_parts(filter_frames=4).eval()
    assert grown.config.seam_filter_frames == 4
    p, t, k = 4, 6, 3
    g = torch.Generator().manual_seed(2)
    body = torch.randn(1, t * p, L.BODY_DIM, generator=g)
    root = torch.randn(1, t * p, 5, generator=g)
    prev, valid = torch.randn(1, 5, generator=g), torch.tensor([1.0])
    with torch.no_grad():
        codes = tok.encode(body)
        assert torch.allclose(
            grown.decode(codes, root, prev, valid), tok.decode(codes, root, prev, valid)
        )
        grown.seam_filter.weight.fill_(0.25)  # a 4-frame moving average
        later = codes.clone()
        later[:, k:] = -later[:, k:]
        d1 = grown.decode(codes, root, prev, valid)
        d2 = grown.decode(later, root, prev, valid)
        assert torch.allclose(d1[:, : k * p], d2[:, : k * p], atol=1e-5)
        assert not torch.allclose(d1[:, k * p], d2[:, k * p], atol=1e-3)
    with pytest.raises(ValueError, match="seam_filter_frames is -1"):
        BodyTokenizer(TokenizerConfig(seam_filter_frames=-1))


def test_seam_overlap_cross_fades_the_previous_tokens_frames_causally() -> None:
    """With an overlap of 2 frames, the first 2 frames of every patch after the call's first
    are the previous token's overlap and the patch's own frames, weighted 2/3, 1/3 and
    1/3, 2/3; no frame depends on a later token; the grown overlap starts as the previous
    patch's last frame."""
    tok = _tokenizer()
    grown = tok.with_seam_parts(overlap_frames=2).eval()
    p, t, k, d = 4, 5, 2, L.BODY_DIM
    g = torch.Generator().manual_seed(3)
    body = torch.randn(1, t * p, d, generator=g)
    root = torch.randn(1, t * p, 5, generator=g)
    prev, valid = torch.randn(1, 5, generator=g), torch.tensor([1.0])
    with torch.no_grad():
        codes = tok.encode(body)
        plain = tok.decode(codes, root, prev, valid)
        faded = grown.decode(codes, root, prev, valid)
        own_heads = [j for j in range(t * p) if j % p < 2 and j >= p]
        others = [j for j in range(t * p) if j not in own_heads]
        assert torch.allclose(faded[:, others], plain[:, others], atol=1e-5)
        for start in range(p, t * p, p):
            last = plain[:, start - 1]
            assert torch.allclose(faded[:, start], (2 * last + plain[:, start]) / 3, atol=1e-5)
            assert torch.allclose(
                faded[:, start + 1], (last + 2 * plain[:, start + 1]) / 3, atol=1e-5
            )
        later = codes.clone()
        later[:, k:] = -later[:, k:]
        changed = grown.decode(later, root, prev, valid)
        assert torch.allclose(changed[:, : k * p], faded[:, : k * p], atol=1e-5)
    # With the contact channels left out, a patch's contacts are its own.
    own_contacts = tok.with_seam_parts(overlap_frames=2, overlap_contacts=False).eval()
    contacts = slice(L.CONTACT_SLICE.start - L.ROOT_DIM, L.CONTACT_SLICE.stop - L.ROOT_DIM)
    with torch.no_grad():
        kept = own_contacts.decode(codes, root, prev, valid)
    assert torch.allclose(kept[..., contacts], plain[..., contacts], atol=1e-5)
    assert not torch.allclose(kept[:, p], faded[:, p])
    assert torch.allclose(kept[:, p, : contacts.start], faded[:, p, : contacts.start], atol=1e-5)
    with pytest.raises(ValueError, match=r"seam_overlap_frames is 5, expected 0\.\.4"):
        BodyTokenizer(TokenizerConfig(seam_overlap_frames=5))


def test_local_root_matches_finite_differences() -> None:
    f = synthetic_clip("walk-turn-left", "normal", 3.0, np.random.default_rng(3))
    root = torch.from_numpy(f[None, :, :5])
    fps = L.FPS
    loc = local_root(root[:, 1:], root[:, 0], torch.ones(1), fps)[0].numpy()
    psi = np.unwrap(np.arctan2(f[:, 4], f[:, 3]))
    assert np.allclose(loc[:, 0], np.diff(psi) * fps, atol=1e-3)
    v = np.diff(f[:, [0, 2]], axis=0) * fps
    c, s = f[1:, 3], f[1:, 4]
    forward = v[:, 0] * s + v[:, 1] * c  # velocity along the heading direction (sin, cos)
    assert np.allclose(loc[:, 2], forward, atol=1e-3)
    assert np.all(loc[:, 2] > 0.5)  # walking forwards
    assert np.allclose(loc[:, 3], f[1:, 1])
    # translation and yaw invariance of the rates
    shifted = root.clone()
    shifted[..., 0] += 5.0
    shifted[..., 2] -= 2.0
    loc2 = local_root(shifted[:, 1:], shifted[:, 0], torch.ones(1), fps)[0].numpy()
    assert np.allclose(loc, loc2, atol=1e-4)
    # without a previous frame the first frame copies the second frame's rates
    loc3 = local_root(root[:, 1:], torch.zeros(1, 5), torch.zeros(1), fps)[0].numpy()
    assert np.allclose(loc3[0, :3], loc3[1, :3]) and np.allclose(loc3[1:], loc[1:], atol=1e-5)


def test_safe_atan2_matches_atan2() -> None:
    a = torch.linspace(-math.pi + 1e-3, math.pi - 1e-3, 1001, dtype=torch.float64)
    r = torch.rand(1001, dtype=torch.float64) + 0.1
    y, x = r * torch.sin(a), r * torch.cos(a)
    assert torch.allclose(safe_atan2(y, x), torch.atan2(y, x), atol=1e-6)
