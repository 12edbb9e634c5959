"""The drop-rig simulator behind the built-in data: contact law and solver, helmet and sensor models, drop sets."""
