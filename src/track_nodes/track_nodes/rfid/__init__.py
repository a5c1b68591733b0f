"""Handheld RFID reader: the (simulated) reader and the particle-filter guidance."""
