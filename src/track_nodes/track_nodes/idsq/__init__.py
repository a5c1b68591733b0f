"""IDSQ sensor network: one node per acoustic or DOA sensor, handing the belief from leader to leader."""
