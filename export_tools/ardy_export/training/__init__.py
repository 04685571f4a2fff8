"""Training of the tokenizer and the denoiser (``ardy-export train ...``)."""
