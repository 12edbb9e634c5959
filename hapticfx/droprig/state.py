"""The layout of the drop rig's state vector, shared by the contact solver and the helmet model.

Block: position ``X, Y``, tilt ``TH`` and their rates ``VX, VY, OM``; helmet crown
height ``YH`` and rate ``VH``; rocking angle ``BE`` and rate ``VB``; running
integrals of the contact force: vertical impulse ``JY`` and torque impulse about
the pivot ``JT``. One impulse per shell mode follows from ``N_RIGID`` on.
"""

X, Y, TH, VX, VY, OM, YH, VH, BE, VB, JY, JT = range(12)
N_RIGID = 12
