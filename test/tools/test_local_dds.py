"""Each process reserves a ROS_DOMAIN_ID of its own, far from the others' (tools.local_dds)."""

import os
import subprocess
import sys

from splines445_ros.tools import local_dds

RESERVE = ('import sys, time; from splines445_ros.tools.local_dds import keep_dds_local, '
           'reserve_domain_id; import os; os.environ.pop("ROS_DOMAIN_ID", None); '
           'keep_dds_local(); print(os.environ["ROS_DOMAIN_ID"], '
           'os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"], reserve_domain_id(), flush=True); '
           'time.sleep(float(sys.argv[1]))')


def reserving(seconds):
    """Start a process that reserves a domain and holds it for ``seconds``."""
    env = dict(os.environ)
    env.pop('ROS_DOMAIN_ID', None)
    env['PYTHONPATH'] = os.pathsep.join(sys.path)
    return subprocess.Popen([sys.executable, '-c', RESERVE, str(seconds)], env=env,
                            stdout=subprocess.PIPE, text=True)


def test_processes_at_the_same_time_get_distinct_domains_apart():
    held = [reserving(20.0) for _ in range(4)]
    try:
        lines = [process.stdout.readline().split() for process in held]
    finally:
        for process in held:
            process.kill()
            process.wait()
    domains = [int(line[0]) for line in lines]
    assert all(line[1] == 'LOCALHOST' for line in lines)
    # The same domain on every call within a process, a different one in each.
    assert all(int(line[2]) == int(line[0]) for line in lines)
    assert len(set(domains)) == 4 and all(1 <= d <= 100 for d in domains), domains
    # Not neighbours of one another (Fast DDS's ports of neighbouring domains overlap).
    assert all(abs(a - b) > 1 for a in domains for b in domains if a != b), domains


def test_a_domain_that_is_set_is_kept(monkeypatch):
    monkeypatch.setenv('ROS_DOMAIN_ID', '77')
    monkeypatch.setenv('ROS_AUTOMATIC_DISCOVERY_RANGE', 'SUBNET')
    local_dds.keep_dds_local()
    assert os.environ['ROS_DOMAIN_ID'] == '77'
    assert os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] == 'LOCALHOST'
