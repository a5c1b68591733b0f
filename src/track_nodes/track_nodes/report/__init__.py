"""Summaries and pictures of recorded bags, one module per scenario."""
