"""The user's commands on trained models and programs: reconstruct, mix and interpolate."""
