"""The finite-element engine: the virtual contact experiment of SPEC section 5."""
