"""Simulated instruments: protocol servers backed by the digital twin (``hil.sim``)."""
