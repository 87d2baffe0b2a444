"""Rigid-body physics over ODE (through odepy). No other layer imports odepy."""
