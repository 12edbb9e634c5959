"""Evaluating interpolators: held-out folds (``folds``), error measures and floors (``measures``),
the runner (``runner``) and its tables and figures (``report``). Used by ``hapticfx bench interpolators``."""
