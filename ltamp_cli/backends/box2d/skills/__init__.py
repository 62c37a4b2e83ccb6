"""The learned Kitchen2D skills. Each module defines ``SPEC``, ``valid_mask`` and ``run``."""
