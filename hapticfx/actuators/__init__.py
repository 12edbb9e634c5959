"""Built-in actuators: a WAV file and memory (for tests and embedding)."""
