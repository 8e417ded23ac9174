"""Identification: data preparation, fit metrics, linear and grey-box fitting, diagnosis.

Depends on :mod:`thermogym.models` only (never on envs or controllers).
"""
