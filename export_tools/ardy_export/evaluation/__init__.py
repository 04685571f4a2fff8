"""Evaluation of generated motion in the ARDY paper's terms (Tables 2 and 3).

* :mod:`.motion_repr`: a translation- and yaw-invariant per-frame motion representation.
* :mod:`.retrieval`: a small contrastive text-motion retrieval evaluator (TMR-like).
* :mod:`.metrics`: foot skate, R-precision, FID and jerk.
"""
