"""hapticfx-example-actuator: the ``csv-logger`` actuator, and a template for your own plugin."""

__version__ = "0.1.0"
