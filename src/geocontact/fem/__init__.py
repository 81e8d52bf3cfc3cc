"""The finite-element engine: the virtual contact experiment of docs/model.md §5."""
