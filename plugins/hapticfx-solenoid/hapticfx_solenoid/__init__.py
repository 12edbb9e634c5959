"""hapticfx-solenoid: a push-pull solenoid behind an Arduino, as a hapticfx actuator.

Importing this package is cheap: pyserial is imported only when a port opens.
"""

__version__ = "0.1.0"
