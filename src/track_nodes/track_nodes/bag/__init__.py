"""Bag tools: recorder, player, recovery of killed recordings, dataset conversion, and their shared API."""
