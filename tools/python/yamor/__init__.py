"""Python client of yamord, the YaMoR host daemon (gRPC API ``yamor.v1.Host``).

    import yamor
    with yamor.Host("127.0.0.1:2224") as host:
        host.open_simulation(world="quadruped")
        host.connect()
        host.control(uart=True, cpg=True, motors=True)
        host.sleep(20)
        print(host.position())

Every call carries a deadline (the ``timeout`` given to :class:`Host`; a
virtual-time ``sleep`` and ``evaluate`` add their simulated duration) and
every failure raises :class:`HostError` with the canonical gRPC code name
(``NOT_FOUND``, ``INVALID_ARGUMENT``, ...). Units: radians, seconds, metres,
Hz for oscillator speed, m/s for velocities. The generated stubs are in
:mod:`yamor.v1.host_pb2` and :mod:`yamor.v1.host_pb2_grpc`.
"""

from yamor.client import (
    Accelerometer,
    ConnectResult,
    Evaluation,
    Event,
    Host,
    HostError,
    Info,
    Morphology,
    OpenedSimulation,
    Orientation,
    Pose,
    Position,
    StateUpdate,
    TrajectorySample,
)

__all__ = [
    "Accelerometer",
    "ConnectResult",
    "Evaluation",
    "Event",
    "Host",
    "HostError",
    "Info",
    "Morphology",
    "OpenedSimulation",
    "Orientation",
    "Pose",
    "Position",
    "StateUpdate",
    "TrajectorySample",
]
__version__ = "0.1.0"
