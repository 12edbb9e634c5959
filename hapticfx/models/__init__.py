"""Built-in impact models."""
