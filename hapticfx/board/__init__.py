"""The accelerometer board that records real drops: its line protocol, an emulator of its firmware, and the recorder."""
