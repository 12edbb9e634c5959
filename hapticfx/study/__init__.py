"""Perceptual studies: study files, schedules, the participant's page, results and their analysis.

Nothing here is imported by ``import hapticfx``; the analysis imports pandas,
statsmodels and matplotlib only inside the functions that need them.
"""
