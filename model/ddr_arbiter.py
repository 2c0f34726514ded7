"""Golden model of :class:`tdicam.hdl.ddr_arbiter.DdrArbiter`'s grant order (several DDR users
on one MIG user interface, Ning et al. 2019 §4.2).

Policy, cycle for cycle: the grant ``g`` (port 0 at reset) and the count ``c`` of commands
taken in this grant; in each cycle the granted port's command is taken when it presents one
(``req[g]``) and the arbiter can take it (``ok[g]``: room in its queues, a write's data word
captured). After ``burst`` commands taken, or at once when ``req[g]`` is low, the grant moves
to the first of ports ``g + 1, g + 2, ..., g + n`` (mod ``n``; ``g`` itself last) presenting a
command this cycle, and ``c`` restarts; none presenting: the grant stays. Round robin among
the requesting ports: a port that keeps requesting waits at most ``(n - 1) * burst`` commands
of the others.
"""

import numpy as np

from tdicam.errors import TdicamError, check_range

__all__ = ["MAX_PORTS", "MAX_BURST", "grants"]

#: Most users one arbiter takes.
MAX_PORTS = 8
#: Most commands one grant may take.
MAX_BURST = 4096


def grants(req, ok, *, burst):
    """The arbiter's grant and take, cycle by cycle.

    Parameters
    ----------
    req, ok : array_like of bool, (cycles, n_ports)
        Per cycle and port: the port presents a command (``app_en``); the arbiter could take
        it were the port granted.
    burst : int
        Most commands a grant.

    Returns
    -------
    grant : ndarray of int64, (cycles,)
        The granted port each cycle.
    take : ndarray of bool, (cycles,)
        The granted port's command is taken that cycle.
    """
    req, ok = np.asarray(req, bool), np.asarray(ok, bool)
    if req.shape != ok.shape or req.ndim != 2:
        raise TdicamError(f"req {req.shape} and ok {ok.shape} must be one (cycles, ports) "
                          f"shape")
    n = check_range("n_ports", req.shape[1], 2, MAX_PORTS)
    check_range("burst", burst, 1, MAX_BURST)
    g = c = 0
    grant = np.zeros(len(req), np.int64)
    take = np.zeros(len(req), bool)
    for t in range(len(req)):
        grant[t] = g
        take[t] = tk = req[t, g] and ok[t, g]
        if (tk and c == burst - 1) or not req[t, g]:
            g = next((k % n for k in range(g + 1, g + n + 1) if req[t, k % n]), g)
            c = 0
        elif tk:
            c += 1
    return grant, take
