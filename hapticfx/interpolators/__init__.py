"""Built-in interpolators (numpy only). Neural ones live in the hapticfx-neural plugin."""
