"""Unplug one simulated host mid-track (issue 15, part 1): an experiment, not a test.

Runs ``python -m track_nodes.launch SCENARIO --processes --hosts 3 --record NAME --rate R`` (as root),
and AT wall seconds after the first leader starts, sets host H's port on the bridge down for
GAP seconds, then up again. Prints the launcher's summary and when the link went down and up.

    .venv/bin/python tools/unplug_host.py [--scenario config/idsq.yaml] [--host 1] [--at 10] [--gap 5]
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
import threading
import time
from pathlib import Path


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument('--scenario', default='config/idsq.yaml')
    ap.add_argument('--host', type=int, default=1)
    ap.add_argument('--at', type=float, default=10.0, help='wall seconds after the first leader starts')
    ap.add_argument('--gap', type=float, default=5.0, help='wall seconds unplugged')
    ap.add_argument('--rate', type=float, default=1.0)
    ap.add_argument('--record', default=f'unplug-{int(time.time())}')
    args = ap.parse_args()
    cmd = [sys.executable, '-m', 'track_nodes.launch', str(Path(args.scenario).resolve()), '--processes',
           '--hosts', '3', '--record', args.record, '--rate', str(args.rate)]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    tag, started, out, err = [], threading.Event(), [], []

    def read(stream, sink, watch):
        for line in stream:
            sink.append(line)
            watch(line)

    def on_out(line):
        if m := re.search(r'hosts: 3 namespaces (\S+)-\*', line):
            tag.append(m.group(1))

    def on_err(line):
        if 'leading from a uniform belief' in line:
            started.set()

    threads = [threading.Thread(target=read, args=(proc.stdout, out, on_out), daemon=True),
               threading.Thread(target=read, args=(proc.stderr, err, on_err), daemon=True)]
    for t in threads:
        t.start()
    if not started.wait(120) or not tag:
        proc.terminate()
        proc.wait()
        print(''.join(out[-20:]), ''.join(err[-20:]))
        return 1
    t0 = time.monotonic()
    time.sleep(args.at)
    port = ['ip', '-n', f'{tag[0]}-hub', 'link', 'set', f'{tag[0]}b{args.host}']
    subprocess.run([*port, 'down'], check=True)
    down = time.monotonic() - t0
    time.sleep(args.gap)
    subprocess.run([*port, 'up'], check=True)
    up = time.monotonic() - t0
    code = proc.wait()
    for t in threads:
        t.join()
    print(f'host {args.host} unplugged at {down:.2f} s, plugged back at {up:.2f} s (wall, after the first leader)')
    print(''.join(line for line in out if 'recording /' not in line))
    print(''.join(line for line in err if 'WARN' in line or 'ERROR' in line)[-4000:])
    return code


if __name__ == '__main__':
    raise SystemExit(main())
