"""The recorder's batch loss counting gives what the per-message one gave (``LossCounter.received``)."""

from __future__ import annotations

import random

from track_nodes.bag.loss_count import LossCounter


def test_received_many_counts_what_received_counts():
    rng = random.Random(3)
    for _ in range(300):
        seqs: list[int | None] = []
        s = rng.randrange(1, 50)
        for _ in range(rng.randrange(1, 40)):
            s = rng.choice([s + 1] * 8 + [s + rng.randrange(2, 6), rng.randrange(1, 5)])  # runs, gaps, restarts
            seqs.append(None if rng.random() < 0.02 else s)
        one, many, publishers = LossCounter(), LossCounter(), rng.choice([1, 1, 1, 2])
        for c in (one, many):
            c.publishers('/t', publishers)
        cuts = sorted({*rng.sample(range(1, len(seqs)), min(3, len(seqs) - 1)), len(seqs)})
        per_message = [one.received('/t', q) for q in seqs]
        batched = [many.received_many('/t', seqs[a:b]) for a, b in zip([0, *cuts[:-1]], cuts, strict=True)]
        assert sum(batched) == sum(per_message) and many.lost == one.lost and many.last('/t') == one.last('/t')
