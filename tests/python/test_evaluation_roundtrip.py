"""``ardy-export eval tokenizer``: clips decoded window by window as the runtime does."""

from __future__ import annotations

import numpy as np
import torch

from ardy_export.evaluation.roundtrip import decode_like_runtime
from ardy_export.models import layout as L
from ardy_export.models.tokenizer import BodyTokenizer, TokenizerConfig


def test_windowed_decode_matches_a_whole_decode_in_its_first_window_only() -> None:
    torch.manual_seed(0)
    tokenizer = BodyTokenizer(
        TokenizerConfig(latent_dim=4, fsq_levels=8, width=16, layers=1, heads=2, ff_mult=2)
    ).eval()
    rng = np.random.default_rng(0)
    frames = 24  # 6 tokens of 4 frames
    features = rng.normal(size=(frames, L.FEATURE_SIZE))
    mean = np.zeros(L.FEATURE_SIZE)
    std = np.ones(L.FEATURE_SIZE)
    whole = decode_like_runtime(tokenizer, features, mean, std, window_tokens=6)
    windows = decode_like_runtime(tokenizer, features, mean, std, window_tokens=2)
    # the root is the clip's own; the body is decoded
    np.testing.assert_array_equal(whole[:, L.ROOT_SLICE], features[:, L.ROOT_SLICE])
    assert not np.allclose(whole[:, L.BODY_SLICE], features[:, L.BODY_SLICE])
    with torch.no_grad():
        body = torch.from_numpy(features[None, :, L.BODY_SLICE].astype(np.float32))
        root = torch.from_numpy(features[None, :, L.ROOT_SLICE].astype(np.float32))
        direct, _ = tokenizer(body, root, root[:, 0], torch.zeros(1))
    np.testing.assert_allclose(whole[:, L.BODY_SLICE], direct[0].numpy(), atol=1e-5)
    # causal: the first window sees the same tokens either way; later windows start afresh
    np.testing.assert_allclose(windows[:8], whole[:8], atol=1e-5)
    assert np.abs(windows[8:] - whole[8:]).max() > 1e-3
