"""Per-step bytes and handoff latency of the IDSQ field, in one process against 3 simulated hosts
(issue 15, part 1): an experiment, not a test. Writes a PNG and a JSON.

For each mode it runs ``python -m track_nodes.launch SCENARIO [--processes --hosts 3] --rate R`` and,
in the launcher's namespace, a probe node that subscribes to every ``/idsq/sensor_<k>/handoff`` and
``/idsq/sensor_<k>/ack`` topic and takes each message with its DDS message info:

- **handoff latency** = source timestamp of the receiver's ack − source timestamp of the sender's
  handoff, matched by (step, sender, receiver): the one-way delivery of the handoff plus the
  receiver's decode, checks and reply (both stamps are the publishers' system clocks, one machine:
  the probe's own position does not enter). Only acks (not nacks) are counted.
- **bytes per step**: the handoff package sizes (``IdsqHandoff.package_bytes``, re-sends included) per led
  step, the same figure as the launcher's summary; and with 3 hosts, what really crossed the bridge:
  the bytes the hub's ports received from the hosts and the launcher's namespace (all DDS traffic:
  handoffs, acks, truth, /clock, estimates to the recorder, discovery), sampled every wall second
  while the track runs, divided by the steps in that time.

    sudo .venv/bin/python tools/handoff_figure.py [--rate 1] [--out docs/figures/idsq_hosts]

Needs root (for the hosts). ROS_DOMAIN_ID is the caller's.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
from watched_launch import WatchedLaunch

from track_nodes.launch.hosts import DISCOVERY_PORT, LAUNCHER_HOST

N_SENSORS = 24
DT = 0.5


class Probe:
    """A node in this process that records the handoffs and acks with their source timestamps."""

    def __init__(self) -> None:
        import rclpy

        from track_msgs import msg as tm
        from track_msgs_py.qos import HANDOFF_QOS
        from track_msgs_py.topics import idsq_ack_topic, idsq_handoff_topic

        self.rclpy = rclpy
        self.ctx = rclpy.Context()
        rclpy.init(context=self.ctx)
        self.node = rclpy.create_node('handoff_probe', context=self.ctx)
        self.handoffs: list[tuple[int, int, int, int, int]] = []  # step, sender, receiver, bytes, source ns
        self.acks: list[tuple[int, int, int, str, int]] = []  # step, sender, receiver, result, source ns
        self.lock = threading.Lock()
        for k in range(N_SENSORS):
            self.node.create_subscription(tm.IdsqHandoff, idsq_handoff_topic(k), self._on_handoff, HANDOFF_QOS)
            self.node.create_subscription(tm.IdsqAck, idsq_ack_topic(k), self._on_ack, HANDOFF_QOS)
        self.executor = rclpy.executors.SingleThreadedExecutor(context=self.ctx)
        self.executor.add_node(self.node)
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._spin, daemon=True)
        self.thread.start()

    def _spin(self) -> None:
        while not self.stop.is_set():
            self.executor.spin_once(timeout_sec=0.1)

    def _on_handoff(self, msg, info) -> None:
        from track_msgs_py.records.idsq import IdsqHandoff

        size = IdsqHandoff.from_msg(msg, frame_id=None).package_bytes
        with self.lock:
            self.handoffs.append((msg.step, msg.sender, msg.receiver, size, info['source_timestamp']))

    def _on_ack(self, msg, info) -> None:
        from track_msgs_py.records.idsq import IdsqAck

        a = IdsqAck.from_msg(msg)
        with self.lock:
            self.acks.append((a.step, a.sender, a.receiver, a.result, info['source_timestamp']))

    def close(self) -> None:
        self.stop.set()
        self.thread.join()
        self.node.destroy_node()
        self.rclpy.shutdown(context=self.ctx)


def probe_main(out: Path) -> int:
    """``--probe FILE``: run the probe (in its own process: its participant reads this environment)
    until stdin closes, then write what it took to FILE."""
    probe = Probe()
    sys.stdin.read()
    time.sleep(0.5)
    probe.close()
    out.write_text(json.dumps({'handoffs': probe.handoffs, 'acks': probe.acks}))
    return 0


def hub_bytes(hub: str) -> int:
    """Bytes received by every port of the hub's bridge (what the namespaces sent onto it)."""
    out = subprocess.run(['ip', '-n', hub, '-s', '-j', 'link', 'show'], capture_output=True, text=True).stdout
    return sum(d['stats64']['rx']['bytes'] for d in json.loads(out or '[]') if d.get('master') == 'br0')


def run_mode(scenario: Path, hosts: int, rate: float, record: str) -> dict:
    cmd = [sys.executable, '-m', 'track_nodes.launch', str(scenario), '--rate', str(rate), '--record', record]
    if hosts:
        cmd += ['--processes', '--hosts', str(hosts)]
    run = WatchedLaunch(cmd)
    env = {**os.environ, 'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST'}
    if hosts:
        run.hosts_known.wait(30)
        import ipaddress
        sub = ipaddress.ip_network(run.subnet)
        env['ROS_DISCOVERY_SERVER'] = f'{sub[LAUNCHER_HOST]}:{DISCOVERY_PORT}'  # the launcher's server
        env['ROS_SUPER_CLIENT'] = 'TRUE'
        env['FASTDDS_BUILTIN_TRANSPORTS'] = 'UDPv4'
    probe_file = Path(f'{record}-probe.json')
    probe_proc = subprocess.Popen([sys.executable, __file__, '--probe', str(probe_file)], stdin=subprocess.PIPE,
                                  env=env, text=True)
    samples = []  # (wall s after the first leader, hub bytes)
    if not run.started.wait(240):
        run.proc.terminate()
    t0 = time.monotonic()
    while run.proc.poll() is None:
        if run.tag:
            samples.append((time.monotonic() - t0, hub_bytes(f'{run.tag}-hub')))
        time.sleep(1.0)
    run.wait()
    probe_proc.communicate('', timeout=60)
    probe = json.loads(probe_file.read_text())
    summary = ''.join(line for line in run.out if line.startswith(('idsq:', '  ')))
    steps_led = int(m.group(1)) if (m := re.search(r'idsq: (\d+) estimates', summary)) else 0
    return {'exit': run.proc.returncode, 'handoffs': probe['handoffs'], 'acks': probe['acks'], 'samples': samples,
            'steps_led': steps_led, 'summary': summary, 'stderr_tail': ''.join(run.err[-5:])}


def figures(raw: dict, rate: float, steps_led: int) -> dict:
    """Per-step bytes and latency (module docstring) of one mode's raw probe data."""
    sent = {}
    for step, sender, receiver, n, ts in raw['handoffs']:
        sent.setdefault((step, sender, receiver), (n, ts))
    lat = {}
    for step, sender, receiver, result, ts in raw['acks']:
        if result == 'ack' and (step, sender, receiver) in sent and step not in lat:
            lat[step] = (ts - sent[(step, sender, receiver)][1]) * 1e-6  # ms
    by_step = {}
    for (step, _, _), (n, _) in sent.items():
        by_step[step] = by_step.get(step, 0) + n
    steps = sorted(set(by_step) | set(lat))
    res = {'steps': steps, 'handoff_bytes': [by_step.get(s, 0) for s in steps],
           'latency_ms': [round(lat[s], 3) if s in lat else None for s in steps]}
    ms = np.array([v for v in res['latency_ms'] if v is not None])
    res['latency_ms_stats'] = {'n': int(ms.size), 'median': round(float(np.median(ms)), 3),
                               'p95': round(float(np.percentile(ms, 95)), 3), 'max': round(float(ms.max()), 3)} \
        if ms.size else {}
    res['handoff_bytes_per_step'] = round(sum(by_step.values()) / max(len(by_step), 1), 1)
    if raw['samples']:
        t = np.array([s[0] for s in raw['samples']])
        b = np.array([s[1] for s in raw['samples']], dtype=float)
        track = t <= steps_led * DT / rate  # while the track runs
        if track.sum() >= 2:
            tt, bb = t[track], b[track]
            res['bridge_bytes_per_step'] = round(float((bb[-1] - bb[0]) / ((tt[-1] - tt[0]) * rate / DT)), 1)
            per = np.diff(bb) / (np.diff(tt) * rate / DT)
            res['bridge_series'] = {'step': [round(float(x) * rate / DT, 1) for x in tt[1:]],
                                    'bytes_per_step': [round(float(x), 1) for x in per]}
    return res


def plot(res: dict, png: Path) -> None:
    from track_experiments.plotting import pyplot

    plt = pyplot()
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4))
    for mode, style in (('in_process', 'o-'), ('hosts_3', 's--')):
        f = res[mode]
        ax1.plot(f['steps'], f['handoff_bytes'], style, ms=3, label=f'{mode}: handoff payload')
        lat = [(s, v) for s, v in zip(f['steps'], f['latency_ms'], strict=True) if v is not None]
        if lat:
            med = f['latency_ms_stats']['median']
            ax2.plot(*zip(*lat, strict=True), style, ms=3, label=f'{mode} (median {med:.2f} ms)')
    br = res['hosts_3'].get('bridge_series')
    if br:
        ax1.plot(br['step'], br['bytes_per_step'], 'k:', label='hosts_3: all traffic on the bridge')
    ax1.set(xlabel='step', ylabel='bytes per step', yscale='log', title='Bytes per step')
    ax2.set(xlabel='step', ylabel='handoff → ack [ms]', yscale='log', title='Handoff latency (source stamps)')
    ax1.legend(fontsize=7)
    ax2.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(png, dpi=120)


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument('--scenario', default='config/idsq.yaml')
    ap.add_argument('--rate', type=float, default=1.0)
    ap.add_argument('--out', default='docs/figures/idsq_hosts', help='writes OUT.png and OUT.json')
    ap.add_argument('--probe', type=Path, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.probe:
        return probe_main(args.probe)
    scenario = Path(args.scenario).resolve()
    stamp = int(time.time())
    res = {'scenario': str(args.scenario), 'rate': args.rate}
    for mode, hosts in (('in_process', 0), ('hosts_3', 3)):
        raw = run_mode(scenario, hosts, args.rate, f'hfig-{mode}-{stamp}')
        res[mode] = {'launcher_exit': raw['exit'], 'steps_led': raw['steps_led'],
                     **figures(raw, args.rate, raw['steps_led'])}
        print(mode, json.dumps({k: v for k, v in res[mode].items() if not isinstance(v, list | dict)}),
              res[mode].get('latency_ms_stats'), flush=True)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.with_suffix('.json').write_text(json.dumps(res, indent=1) + '\n')
    plot(res, out.with_suffix('.png'))
    print(f'wrote {out.with_suffix(".png")} and {out.with_suffix(".json")}')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
