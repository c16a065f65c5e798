"""Pure numpy/scipy building blocks: gridding, morphology, interpolation."""
