"""Record every lock-step scenario with one epoch and print a digest of each topic's payloads.

A refactor that must not change behaviour is checked by running this before and after it:

    .venv/bin/python tools/scenario_digests.py --out /tmp/before.json
    ... change ...   (or: PYTHONPATH=<a worktree of the old commit>/src/<pkg>:... for the "before")
    .venv/bin/python tools/scenario_digests.py --compare /tmp/before.json

Each topic's digest is the SHA-256 over the sorted SHA-256s of its messages, with the message count:
the same messages give the same digest whatever the interleaving of two publishers on one topic
(``/tf`` of the rfid pair), which the recorder does not fix. A message is hashed as rosbags
serializes it again after decoding, because the CDR padding bytes of a live publisher are not
guaranteed zero (the same message can arrive with different padding).
``victoria_park`` is left out: it runs on wall time (the player's /clock), so its bag is not
reproducible by construction.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import subprocess
import sys
import tempfile
from pathlib import Path

from rosbags.rosbag2 import Reader

from track_nodes.bag.typestore import typestore

CONFIG = Path(__file__).resolve().parents[1] / 'src/track_nodes/config'
EPOCH = '2026-01-01T00:00:00'
WALL_TIME = {'victoria_park'}


def digest(bag: Path) -> dict[str, list]:
    """topic -> [count, sha256 of the sorted payload sha256s]."""
    ts = typestore()  # the Jazzy types and track_msgs
    hashes: dict[str, list[bytes]] = {}
    with Reader(bag) as reader:
        for conn, _, raw in reader.messages():
            canonical = ts.serialize_cdr(ts.deserialize_cdr(raw, conn.msgtype), conn.msgtype)
            hashes.setdefault(conn.topic, []).append(hashlib.sha256(canonical).digest())
    return {t: [len(h), hashlib.sha256(b''.join(sorted(h))).hexdigest()] for t, h in sorted(hashes.items())}


def record(scenario: str, cwd: Path) -> dict[str, list]:
    cmd = [sys.executable, '-m', 'track_nodes.launch', scenario, '--record', scenario, '--epoch', EPOCH]
    proc = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=900)
    if proc.returncode != 0:
        raise SystemExit(f'{scenario}: exit {proc.returncode}\n{proc.stderr[-2000:]}')
    return digest(cwd / 'bags' / scenario)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('--out', type=Path, help='write the digests to this JSON file')
    ap.add_argument('--compare', type=Path, help='compare with digests written by --out; exit 1 on a difference')
    ap.add_argument('scenarios', nargs='*', help='default: every scenario in config/ but the wall-time ones')
    args = ap.parse_args()
    names = args.scenarios or sorted(p.stem for p in CONFIG.glob('*.yaml') if p.stem not in WALL_TIME)
    result = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name in names:
            result[name] = record(name, Path(tmp))
            print(f'{name}: {sum(c for c, _ in result[name].values())} messages on {len(result[name])} topics',
                  flush=True)
    if args.out:
        args.out.write_text(json.dumps(result, indent=1) + '\n')
    if args.compare:
        before = json.loads(args.compare.read_text())
        differ = [f'{s}{t}' for s in names for t in sorted(set(before.get(s, {})) | set(result[s]))
                  if before.get(s, {}).get(t) != result[s].get(t)]
        print('identical' if not differ else 'differ: ' + ', '.join(differ))
        return 1 if differ else 0
    return 0


if __name__ == '__main__':
    sys.exit(main())
