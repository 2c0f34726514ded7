"""Formal-proof harnesses (not part of the gateware)."""
