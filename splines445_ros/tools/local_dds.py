"""
DDS traffic on this machine only, each run in a domain no other run holds at the time.

Every test, demo and benchmark process calls :func:`keep_dds_local` before
its first node: discovery stays on the loopback
(``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``), and unless ``ROS_DOMAIN_ID``
is set, the process takes a domain that no other process on this machine
has reserved.  A reservation is a TCP port bound for the process's life,
``PORT_BASE`` + the domain, the convention of ROS 2's own
``domain_coordinator``, so its test runs and ours keep apart.  The domains
are tried :data:`DOMAIN_STEP` apart (1, 42, 83, 24, ...): neighbouring
domains' Fast DDS ports overlap once a process holds many participants.  A
domain chosen from the process id (the earlier rule) gave two runs at the
same time the same domain one time in a hundred.
"""

import os
import socket

PORT_BASE = 32768
DOMAIN_STEP = 41
DOMAINS = 100
_reservation = []   # the bound socket, kept open for the life of the process


def keep_dds_local():
    """Force loopback-only discovery, and a domain of this process's own unless one is set."""
    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    if 'ROS_DOMAIN_ID' not in os.environ:
        os.environ['ROS_DOMAIN_ID'] = str(reserve_domain_id())


def reserve_domain_id():
    """
    Return a domain (1-100) reserved for this process, the first free one of 1, 42, 83, ...

    The same one on every call.  When every port is taken (or none can be
    bound), the domain comes from the process id, as before.
    """
    if _reservation:
        return _reservation[0][0]
    for k in range(DOMAINS):
        domain = 1 + (k * DOMAIN_STEP) % DOMAINS
        held = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        try:
            held.bind(('', PORT_BASE + domain))
        except OSError:
            held.close()
            continue
        _reservation.append((domain, held))
        return domain
    return 1 + os.getpid() % DOMAINS
