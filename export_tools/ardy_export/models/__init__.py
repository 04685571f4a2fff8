"""ARDY models: the body tokenizer (FSQ autoencoder) and the two-stage denoiser."""

from ardy_export.models.denoiser import Denoiser, DenoiserConfig
from ardy_export.models.fsq import FSQ
from ardy_export.models.graphs import DecoderGraph, EncoderGraph
from ardy_export.models.tokenizer import BodyTokenizer, TokenizerConfig

__all__ = [
    "FSQ",
    "BodyTokenizer",
    "DecoderGraph",
    "Denoiser",
    "DenoiserConfig",
    "EncoderGraph",
    "TokenizerConfig",
]
