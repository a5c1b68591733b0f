"""Bag tools: recorder, player, recovery of killed recordings, dataset conversion, the frame check (``frames``),
and their shared API."""
