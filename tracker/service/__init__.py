"""Station mode: a ground station run unattended (``tracker station run``).

:mod:`~tracker.service.board` holds what the station shows; the service loop, the status page
and the rotctld-compatible control port are modules beside it (``docs/station.md``).
"""
