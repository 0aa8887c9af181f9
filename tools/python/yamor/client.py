"""The :class:`Host` wrapper over the generated ``yamor.v1.Host`` stub."""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from typing import Dict, Iterable, Iterator, List, Mapping, Optional, Sequence, Tuple, Union

import grpc
from google.protobuf import empty_pb2

from yamor.v1 import host_pb2 as pb
from yamor.v1 import host_pb2_grpc as pb_grpc

DEFAULT_ADDRESS = "127.0.0.1:2224"
DEFAULT_TIMEOUT = 10.0

_CONNECTORS = {
    "front": pb.CONNECTOR_FRONT,
    "rear": pb.CONNECTOR_REAR,
    "left": pb.CONNECTOR_LEFT,
    "right": pb.CONNECTOR_RIGHT,
    "top": pb.CONNECTOR_TOP,
    "bottom": pb.CONNECTOR_BOTTOM,
}
_MOTOR_DEFECTS = {"ok": pb.MOTOR_OK, "limp": pb.MOTOR_LIMP, "stuck": pb.MOTOR_STUCK}

Vector = Tuple[float, float, float]
Quaternion = Tuple[float, float, float, float]


class HostError(Exception):
    """A failed call: the canonical gRPC code name and the daemon's message.

    ``code`` is the name (``"NOT_FOUND"``), ``status`` the
    :class:`grpc.StatusCode`, ``message`` the daemon's text, ``method`` the RPC.
    """

    def __init__(self, status: grpc.StatusCode, message: str, method: str = ""):
        self.status = status
        self.code = status.name
        self.message = message
        self.method = method
        super().__init__(f"{self.code}: {message}")

    @property
    def code_number(self) -> int:
        """The numeric gRPC code (5 for NOT_FOUND), as yamorctl exits with."""
        return self.status.value[0]


@dataclass
class Frame:
    """One picture of a recording (RecordFrames)."""

    index: int
    time: float  # simulated time of the scene [s]
    png: bytes


@dataclass(frozen=True)
class Position:
    """Central module position (RobotPosition)."""

    x: float  #: [m]
    y: float  #: [m]
    z: float  #: [m], up
    orientation: Quaternion  #: (w, x, y, z)
    time: float  #: time of the sample [s]
    source: str  #: "simulation" or "led-tracker"

    @property
    def xyz(self) -> Vector:
        """(x, y, z) [m]."""
        return (self.x, self.y, self.z)


@dataclass(frozen=True)
class Pose:
    """A position [m] and a unit quaternion (w, x, y, z)."""

    position: Vector
    orientation: Quaternion


@dataclass(frozen=True)
class ConnectResult:
    """Result of ConnectRobot."""

    links: int  #: links established
    elapsed: float  #: wall-clock seconds the connection took
    frames_sent: int  #: SNP frames sent


@dataclass(frozen=True)
class OpenedSimulation:
    """Result of OpenSimulation."""

    module_ids: List[int]  #: modules of the opened world
    central_module: int  #: the tracked module


@dataclass(frozen=True)
class Info:
    """Result of GetInfo."""

    version: str
    backend: str  #: "simulation", "serial" or "none"
    worker_capacity: int  #: Evaluate calls run in parallel
    world: str
    master_node: int
    connected: bool
    free_run_factor: float
    max_concurrent_calls: int
    builtin_worlds: List[str]


@dataclass(frozen=True)
class Morphology:
    """Result of GetMorphology."""

    xml: str
    central_module: int


@dataclass(frozen=True)
class Accelerometer:
    """One accelerometer sample: raw counts and acceleration [m/s^2] (module frame)."""

    counts: Tuple[int, int, int]
    acceleration: Vector


@dataclass(frozen=True)
class Orientation:
    """A module's orientation from its accelerometer (GetOrientation)."""

    valid: bool           # the samples' mean looks like gravity alone
    up: Vector            # world up in the module frame (unit)
    tilt: float           # angle of up to the reference [rad]
    upside_down: bool     # valid and tilt > 120 degrees
    magnitude: float      # |mean| [m/s^2]
    max_deviation: float  # largest | |sample| - g | [m/s^2]
    samples: int


@dataclass(frozen=True)
class Event:
    """A state event of WatchState ("module_connected", "defect_set", ...)."""

    kind: str
    module_id: int
    detail: str


@dataclass(frozen=True)
class StateUpdate:
    """One WatchState update."""

    time: float  #: [s]
    central: Pose
    velocity: Vector  #: [m/s]
    events: List[Event] = field(default_factory=list)


@dataclass(frozen=True)
class TrajectorySample:
    """Central module position at a time since the start of an evaluation."""

    time: float
    position: Vector


@dataclass(frozen=True)
class Evaluation:
    """Result of Evaluate."""

    velocity: float  #: distance / duration [m/s] (thesis 6.2.1)
    distance: float  #: [m] on the ground plane
    final_pose: Pose
    trajectory: List[TrajectorySample]
    diverged: bool
    divergence: str
    wall_seconds: float
    #: With ``frame_rate`` > 0: the frames of the evaluation (PNG), t = 0, 1/rate, ...
    frames: List["Frame"] = field(default_factory=list)
    #: With ``mp4``: the film as one H.264 MP4 made by the daemon (b"" when it cannot run ffmpeg)
    mp4: bytes = b""
    mp4_frames: int = 0  #: frames in ``mp4``
    video_note: str = ""  #: why ``mp4`` is empty although asked for


def _vector(v: pb.Vector3) -> Vector:
    return (v.x, v.y, v.z)


def _quaternion(q: pb.Quaternion) -> Quaternion:
    return (q.w, q.x, q.y, q.z)


def _pose(p: pb.Pose) -> Pose:
    return Pose(_vector(p.position), _quaternion(p.orientation))


def _switch(value: Optional[bool]) -> int:
    if value is None:
        return pb.SWITCH_UNCHANGED
    return pb.SWITCH_ON if value else pb.SWITCH_OFF


def _read_text(path: Union[str, os.PathLike]) -> str:
    with open(path, encoding="utf-8") as f:
        return f.read()


class Host:
    """A connection to one yamord.

    ``Host(address, timeout)`` opens an insecure channel; ``timeout`` is the
    deadline of every call in seconds (long calls add their duration).
    Methods follow the RPCs of ``yamor.v1.Host`` with Pythonic names; each
    takes an optional ``timeout=`` overriding the deadline of that call.
    Use as a context manager, or call :meth:`close`.

    Thread-safety: a Host may be shared by threads (gRPC channels are
    thread-safe); :meth:`watch` generators belong to the thread iterating them.
    """

    def __init__(self, address: str = DEFAULT_ADDRESS, timeout: float = DEFAULT_TIMEOUT):
        if not timeout > 0:
            raise ValueError(f"timeout {timeout} must be > 0 seconds")
        self.address = address
        self.timeout = float(timeout)
        # Frames (snapshot, frames) can be PNGs beyond gRPC's default 4 MB.
        self._channel = grpc.insecure_channel(
            address, options=[("grpc.max_receive_message_length", 256 << 20)])
        self._stub = pb_grpc.HostStub(self._channel)

    # ---- plumbing -----------------------------------------------------------

    @property
    def stub(self) -> pb_grpc.HostStub:
        """The generated stub, for calls the wrapper does not cover."""
        return self._stub

    @property
    def channel(self) -> grpc.Channel:
        """The underlying gRPC channel."""
        return self._channel

    def close(self) -> None:
        """Closes the channel; later calls fail."""
        self._channel.close()

    def __enter__(self) -> "Host":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def wait_ready(self, timeout: Optional[float] = None) -> None:
        """Waits until the channel connects; HostError UNAVAILABLE otherwise."""
        try:
            grpc.channel_ready_future(self._channel).result(
                timeout=self.timeout if timeout is None else timeout)
        except grpc.FutureTimeoutError:
            raise HostError(grpc.StatusCode.UNAVAILABLE,
                            f"cannot reach yamord at {self.address}") from None

    def _deadline(self, timeout: Optional[float], extra: float = 0.0) -> float:
        if timeout is not None:
            if not timeout > 0:
                raise ValueError(f"timeout {timeout} must be > 0 seconds")
            return float(timeout)
        return self.timeout + max(0.0, extra)

    def _call(self, method: str, request, timeout: Optional[float] = None, extra: float = 0.0):
        try:
            return getattr(self._stub, method)(request, timeout=self._deadline(timeout, extra))
        except grpc.RpcError as e:
            raise HostError(e.code(), e.details() or "", method) from None

    _EMPTY = empty_pb2.Empty()

    def _module_value(self, method: str, module_id: int, timeout: Optional[float]) -> float:
        return self._call(method, pb.ModuleRequest(module_id=module_id), timeout).value

    def _set_module_value(self, method: str, module_id: int, value: float,
                          timeout: Optional[float]) -> None:
        self._call(method, pb.SetModuleValueRequest(module_id=module_id, value=value), timeout)

    # ---- IYaMoRHost3 --------------------------------------------------------

    def elapsed_time(self, timeout: Optional[float] = None) -> float:
        """Virtual time since the simulation was opened [s] (ElapsedTime)."""
        return self._call("ElapsedTime", self._EMPTY, timeout).seconds

    def position(self, timeout: Optional[float] = None) -> Position:
        """Position of the central module (RobotPosition)."""
        r = self._call("RobotPosition", self._EMPTY, timeout)
        return Position(r.position.x, r.position.y, r.position.z, _quaternion(r.orientation),
                        r.time, r.source)

    def simulated_position(self, timeout: Optional[float] = None) -> Position:
        """The simulation's own position of the central module, whatever the
        position source (SimulatedPosition; UNIMPLEMENTED on a real robot)."""
        r = self._call("SimulatedPosition", self._EMPTY, timeout)
        return Position(r.position.x, r.position.y, r.position.z, _quaternion(r.orientation),
                        r.time, r.source)

    def simulation_mode_enabled(self, timeout: Optional[float] = None) -> bool:
        """Whether a simulation is open (SimulationModeEnabled)."""
        return self._call("SimulationModeEnabled", self._EMPTY, timeout).enabled

    def add_coupling(self, from_id: int, to_id: int, phase: float, weight: float,
                     timeout: Optional[float] = None) -> None:
        """Adds or replaces the coupling from -> to (AddCoupling)."""
        self._call("AddCoupling", pb.AddCouplingRequest(from_id=from_id, to_id=to_id,
                                                        phase=phase, weight=weight), timeout)

    def close_simulation(self, timeout: Optional[float] = None) -> None:
        """Closes the simulation (CloseSimulation)."""
        self._call("CloseSimulation", self._EMPTY, timeout)

    def connect(self, link_timeout: float = 0.0, links_only: bool = False,
                timeout: Optional[float] = None) -> ConnectResult:
        """Builds the robot's bluetooth network and sends the configuration (ConnectRobot).

        ``link_timeout``: per-link acknowledgement wait [s], 0 = daemon default.
        """
        r = self._call("ConnectRobot", pb.ConnectRobotRequest(link_timeout=link_timeout,
                                                              links_only=links_only), timeout)
        return ConnectResult(r.links, r.elapsed, r.frames_sent)

    def flush(self, timeout: Optional[float] = None) -> int:
        """Sends queued parameter changes; returns the SNP frames sent (Flush)."""
        return self._call("Flush", self._EMPTY, timeout).frames_sent

    def modules(self, timeout: Optional[float] = None) -> List[int]:
        """Module ids of the configuration, in order (GetAllModulesId)."""
        return list(self._call("GetAllModulesId", self._EMPTY, timeout).module_ids)

    def phase(self, from_id: int, to_id: int, timeout: Optional[float] = None) -> float:
        """Phase bias of the coupling from -> to [rad] (GetCouplingPhase)."""
        return self._call("GetCouplingPhase", pb.CouplingRequest(from_id=from_id, to_id=to_id),
                          timeout).value

    def set_phase(self, from_id: int, to_id: int, value: float,
                  timeout: Optional[float] = None) -> None:
        """Sets the phase bias of an existing coupling [rad] (SetCouplingPhase)."""
        self._call("SetCouplingPhase",
                   pb.SetCouplingValueRequest(from_id=from_id, to_id=to_id, value=value), timeout)

    def weight(self, from_id: int, to_id: int, timeout: Optional[float] = None) -> float:
        """Weight of the coupling from -> to (GetCouplingWeight)."""
        return self._call("GetCouplingWeight", pb.CouplingRequest(from_id=from_id, to_id=to_id),
                          timeout).value

    def set_weight(self, from_id: int, to_id: int, value: float,
                   timeout: Optional[float] = None) -> None:
        """Sets the weight of an existing coupling (SetCouplingWeight)."""
        self._call("SetCouplingWeight",
                   pb.SetCouplingValueRequest(from_id=from_id, to_id=to_id, value=value), timeout)

    def amplitude(self, module_id: int, timeout: Optional[float] = None) -> float:
        """Oscillator amplitude [rad] (GetModuleAmplitude)."""
        return self._module_value("GetModuleAmplitude", module_id, timeout)

    def set_amplitude(self, module_id: int, value: float, timeout: Optional[float] = None) -> None:
        """Sets the oscillator amplitude [rad] (SetModuleAmplitude)."""
        self._set_module_value("SetModuleAmplitude", module_id, value, timeout)

    def max_angle(self, module_id: int, timeout: Optional[float] = None) -> float:
        """Upper servo set-point limit [rad] (GetModuleMaxAngle)."""
        return self._module_value("GetModuleMaxAngle", module_id, timeout)

    def set_max_angle(self, module_id: int, value: float, timeout: Optional[float] = None) -> None:
        """Sets the upper limit [rad] (SetModuleMaxAngle)."""
        self._set_module_value("SetModuleMaxAngle", module_id, value, timeout)

    def min_angle(self, module_id: int, timeout: Optional[float] = None) -> float:
        """Lower servo set-point limit [rad] (GetModuleMinAngle)."""
        return self._module_value("GetModuleMinAngle", module_id, timeout)

    def set_min_angle(self, module_id: int, value: float, timeout: Optional[float] = None) -> None:
        """Sets the lower limit [rad] (SetModuleMinAngle)."""
        self._set_module_value("SetModuleMinAngle", module_id, value, timeout)

    def offset(self, module_id: int, timeout: Optional[float] = None) -> float:
        """Oscillator offset [rad] (GetModuleOffset)."""
        return self._module_value("GetModuleOffset", module_id, timeout)

    def set_offset(self, module_id: int, value: float, timeout: Optional[float] = None) -> None:
        """Sets the oscillator offset [rad] (SetModuleOffset)."""
        self._set_module_value("SetModuleOffset", module_id, value, timeout)

    def speed(self, module_id: int, timeout: Optional[float] = None) -> float:
        """Oscillator frequency [Hz] (GetModuleSpeed)."""
        return self._module_value("GetModuleSpeed", module_id, timeout)

    def set_speed(self, module_id: int, value: float, timeout: Optional[float] = None) -> None:
        """Sets the oscillator frequency [Hz] (SetModuleSpeed)."""
        self._set_module_value("SetModuleSpeed", module_id, value, timeout)

    def open_simulation(self, world: str = "", *, morphology_xml: str = "",
                        morphology_file: Optional[Union[str, os.PathLike]] = None,
                        config_xml: str = "",
                        config_file: Optional[Union[str, os.PathLike]] = None,
                        seed: int = 0, time_step: float = 0.0,
                        timeout: Optional[float] = None) -> OpenedSimulation:
        """Opens a simulation (OpenSimulation).

        ``world``: a built-in world name, "" for the daemon's default. A
        morphology (XML text or file) overrides it; a configuration (text or
        file) replaces the world's built-in one.
        """
        if morphology_file is not None:
            morphology_xml = _read_text(morphology_file)
        if config_file is not None:
            config_xml = _read_text(config_file)
        r = self._call("OpenSimulation", pb.OpenSimulationRequest(
            world=world, morphology_xml=morphology_xml, config_xml=config_xml, seed=seed,
            time_step=time_step), timeout)
        return OpenedSimulation(list(r.module_ids), r.central_module)

    def refresh(self, timeout: Optional[float] = None) -> int:
        """Resends every parameter; returns the SNP frames sent (Refresh)."""
        return self._call("Refresh", self._EMPTY, timeout).frames_sent

    def remove_all_couplings(self, timeout: Optional[float] = None) -> None:
        """Removes every coupling, queued until flush (RemoveAllCoupling)."""
        self._call("RemoveAllCoupling", self._EMPTY, timeout)

    def control(self, uart: Optional[bool] = None, cpg: Optional[bool] = None,
                motors: Optional[bool] = None, modules: Optional[Iterable[int]] = None,
                timeout: Optional[float] = None) -> None:
        """Tristate control message (SendControlMessage, thesis C.2.4).

        True turns a switch on, False off, None leaves it unchanged.
        ``modules``: ids to address; None addresses every module.
        """
        request = pb.ControlMessageRequest(uart=_switch(uart), cpg=_switch(cpg),
                                           motors=_switch(motors))
        if modules is None:
            request.all = True
        else:
            request.module_ids.extend(modules)
        self._call("SendControlMessage", request, timeout)

    def sleep(self, seconds: float, real_time: bool = False,
              timeout: Optional[float] = None) -> float:
        """Waits ``seconds`` (virtual time unless ``real_time``); returns the time after (Sleep).

        The deadline is the Host timeout plus ``seconds``.
        """
        extra = seconds if math.isfinite(seconds) else 0.0
        return self._call("Sleep", pb.SleepRequest(seconds=seconds, real_time=real_time),
                          timeout, extra).time

    # ---- beyond YaMoR Host 3 ------------------------------------------------

    def info(self, timeout: Optional[float] = None) -> Info:
        """Version, backend, worker capacity, world (GetInfo)."""
        r = self._call("GetInfo", self._EMPTY, timeout)
        return Info(r.version, r.backend, r.worker_capacity, r.world, r.master_node, r.connected,
                    r.free_run_factor, r.max_concurrent_calls, list(r.builtin_worlds))

    def load_config(self, xml: str, source_name: str = "",
                    timeout: Optional[float] = None) -> None:
        """Replaces the robot configuration with thesis-schema XML (LoadConfig)."""
        self._call("LoadConfig", pb.LoadConfigRequest(config_xml=xml, source_name=source_name),
                   timeout)

    def load_config_file(self, path: Union[str, os.PathLike],
                         timeout: Optional[float] = None) -> None:
        """LoadConfig with the contents of a file (errors name the file)."""
        self.load_config(_read_text(path), os.fspath(path), timeout)

    def save_config(self, timeout: Optional[float] = None) -> str:
        """The current robot configuration as canonical XML (SaveConfig)."""
        return self._call("SaveConfig", self._EMPTY, timeout).config_xml

    def morphology(self, timeout: Optional[float] = None) -> Morphology:
        """The open world's morphology XML and central module (GetMorphology)."""
        r = self._call("GetMorphology", self._EMPTY, timeout)
        return Morphology(r.morphology_xml, r.central_module)

    def connect_modules(self, from_id: int, from_connector: Union[str, int], to_id: int,
                        to_connector: Union[str, int], angle_degrees: float,
                        timeout: Optional[float] = None) -> None:
        """Attaches free module from_id to to_id (ConnectModules, thesis C.2.7).

        Connectors: "front", "rear", "left", "right", "top", "bottom" (or the
        enum numbers); the angle is a multiple of 15 degrees.
        """
        self._call("ConnectModules", pb.ConnectModulesRequest(
            from_id=from_id, from_connector=self._connector(from_connector), to_id=to_id,
            to_connector=self._connector(to_connector), angle_degrees=angle_degrees), timeout)

    @staticmethod
    def _connector(name: Union[str, int]) -> int:
        if isinstance(name, int):
            return name
        try:
            return _CONNECTORS[name.lower()]
        except KeyError:
            raise ValueError(f"connector {name!r} is not one of {', '.join(_CONNECTORS)}") from None

    def disconnect_module(self, module_id: int, timeout: Optional[float] = None) -> None:
        """Detaches a module and puts it away (DisconnectModule)."""
        self._call("DisconnectModule", pb.ModuleRequest(module_id=module_id), timeout)

    def run_script(self, xml: str, timeout: Optional[float] = None) -> None:
        """Runs a transformation script (RunTransformationScript)."""
        self._call("RunTransformationScript", pb.RunTransformationScriptRequest(script_xml=xml),
                   timeout)

    def run_script_file(self, path: Union[str, os.PathLike],
                        timeout: Optional[float] = None) -> None:
        """RunTransformationScript with the contents of a file."""
        self.run_script(_read_text(path), timeout)

    def set_motor_defect(self, module_id: int, defect: str = "limp",
                         timeout: Optional[float] = None) -> None:
        """Marks a motor "limp", "stuck" or "ok" (SetMotorDefect, thesis C.2.6)."""
        try:
            value = _MOTOR_DEFECTS[defect.lower()]
        except KeyError:
            raise ValueError(f"motor defect {defect!r} is not one of limp, stuck, ok") from None
        self._call("SetMotorDefect", pb.SetMotorDefectRequest(module_id=module_id, defect=value),
                   timeout)

    def set_module_defect(self, module_id: int, defective: bool = True,
                          timeout: Optional[float] = None) -> None:
        """Marks a whole module defect, or repaired (SetModuleDefect)."""
        self._call("SetModuleDefect",
                   pb.SetModuleDefectRequest(module_id=module_id, defective=defective), timeout)

    def set_ground(self, friction: Optional[float] = None, slope: Optional[float] = None,
                   slope_direction: Optional[float] = None,
                   timeout: Optional[float] = None) -> None:
        """Changes the ground; None leaves a value as it is (SetGround)."""
        request = pb.SetGroundRequest()
        if friction is not None:
            request.friction = friction
        if slope is not None:
            request.slope = slope
        if slope_direction is not None:
            request.slope_direction = slope_direction
        self._call("SetGround", request, timeout)

    def servo_angles(self, modules: Optional[Iterable[int]] = None,
                     timeout: Optional[float] = None) -> Dict[int, float]:
        """Servo angles [rad] by module id, all modules when None (GetServoAngles)."""
        request = pb.GetServoAnglesRequest(module_ids=list(modules or []))
        r = self._call("GetServoAngles", request, timeout)
        return {a.module_id: a.angle for a in r.angles}

    def accelerometer(self, module_id: int, samples: int = 1,
                      timeout: Optional[float] = None) -> List[Accelerometer]:
        """Recent accelerometer samples, oldest first (GetAccelerometer)."""
        r = self._call("GetAccelerometer",
                       pb.GetAccelerometerRequest(module_id=module_id, samples=samples), timeout)
        return [Accelerometer((s.x, s.y, s.z), _vector(s.acceleration)) for s in r.samples]

    def orientation(self, module_id: int, samples: int = 0,
                    reference_up: Optional[Tuple[float, float, float]] = None,
                    timeout: Optional[float] = None) -> Orientation:
        """Orientation of a module from its latest accelerometer samples (GetOrientation).

        samples: 1..16, 0 = 16. reference_up: the module's up direction when the
        robot stands upright (module frame); None = its +z axis.
        """
        request = pb.GetOrientationRequest(module_id=module_id, samples=samples)
        if reference_up is not None:
            request.reference_up.x, request.reference_up.y, request.reference_up.z = reference_up
        r = self._call("GetOrientation", request, timeout)
        return Orientation(r.valid, _vector(r.up), r.tilt, r.upside_down, r.magnitude,
                           r.max_deviation, r.samples)

    def reset(self, timeout: Optional[float] = None) -> None:
        """Restores the simulation to its state when opened (ResetSimulation)."""
        self._call("ResetSimulation", self._EMPTY, timeout)

    def turn_upside_down(self, timeout: Optional[float] = None) -> None:
        """Turns the simulated robot upside down about its centre (TurnUpsideDown)."""
        self._call("TurnUpsideDown", self._EMPTY, timeout)

    def set_free_run(self, real_time_factor: float, timeout: Optional[float] = None) -> None:
        """Steps the world in the background at a real-time factor; 0 stops (SetFreeRun)."""
        self._call("SetFreeRun", pb.SetFreeRunRequest(real_time_factor=real_time_factor),
                   timeout)

    def watch(self, period: float = 0.1, count: Optional[int] = None,
              timeout: Optional[float] = None) -> Iterator[StateUpdate]:
        """Yields the robot's state every ``period`` seconds (WatchState).

        Updates come while the world advances (a Sleep, free-run). Stops after
        ``count`` updates if given. Deadline of the whole stream: ``timeout``
        if given, else the Host timeout plus count * period when ``count`` is
        given, else none (close the generator to end the stream).
        """
        if timeout is None and count is not None:
            timeout = self.timeout + count * max(period, 0.0)
        call = self._stub.WatchState(pb.WatchStateRequest(period=period),
                                     timeout=None if timeout is None else self._deadline(timeout))
        received = 0
        try:
            for u in call:
                yield StateUpdate(u.time, _pose(u.central), _vector(u.velocity),
                                  [Event(e.kind, e.module_id, e.detail) for e in u.events])
                received += 1
                if count is not None and received >= count:
                    return
        except grpc.RpcError as e:
            if e.code() == grpc.StatusCode.CANCELLED and call.cancelled():
                return
            raise HostError(e.code(), e.details() or "", "WatchState") from None
        finally:
            call.cancel()

    def evaluate(self, params: Optional[Union[Mapping[str, float],
                                               Sequence[Tuple[str, float]]]] = None, *,
                 config_xml: str = "", config_file: Optional[Union[str, os.PathLike]] = None,
                 world: str = "", morphology_xml: str = "", warmup: float = 0.0,
                 duration: float = 0.0, seed: int = 0, trajectory_period: float = 0.0,
                 time_step: float = 0.0,
                 motor_defects: Optional[Mapping[int, str]] = None,
                 module_defects: Iterable[int] = (), friction: Optional[float] = None,
                 slope: Optional[float] = None, slope_direction: Optional[float] = None,
                 upside_down: bool = False, frame_rate: float = 0.0, width: int = 320,
                 height: int = 240, camera: str = "follow", distance: Optional[float] = None,
                 elevation: Optional[float] = None, azimuth: Optional[float] = None,
                 labels: bool = True, legend: bool = True, mp4: bool = False,
                 png_frames: Iterable[int] = (),
                 timeout: Optional[float] = None) -> Evaluation:
        """Stateless gait evaluation on the daemon's worker pool (Evaluate).

        ``params``: parameter values by DESIGN name ("amplitude.3",
        "phase.2.5", ...) over the configuration. warmup/duration 0 mean the
        defaults (8 s, 12 s). The deadline adds warm-up plus duration.
        The evaluated robot's condition: ``motor_defects`` maps module ids to
        "limp", "stuck" or "ok"; ``module_defects`` lists defective modules;
        ``friction``, ``slope`` and ``slope_direction`` change the ground
        (None keeps the world's); ``upside_down`` starts it turned over.
        ``frame_rate`` > 0 films the evaluation (EvaluateRequest.frames): the
        result's ``frames`` hold a PNG every 1/frame_rate simulated seconds of
        it, warm-up included, ``width`` x ``height``, camera options as
        :meth:`snapshot` (follow only); the deadline adds 0.2 s per frame.
        ``mp4`` has the daemon make the film into one MP4 itself (its ffmpeg)
        and send as PNG only the frames indexed in ``png_frames``; a daemon
        without ffmpeg sends every frame and says why in ``video_note``.
        """
        if config_file is not None:
            config_xml = _read_text(config_file)
        items = params.items() if isinstance(params, Mapping) else (params or [])
        defects = []
        for module, defect in (motor_defects or {}).items():
            try:
                defects.append(pb.SetMotorDefectRequest(module_id=module,
                                                        defect=_MOTOR_DEFECTS[defect.lower()]))
            except KeyError:
                raise ValueError(f"motor defect {defect!r} is not one of limp, stuck, ok") from None
        request = pb.EvaluateRequest(
            config_xml=config_xml, world=world, morphology_xml=morphology_xml,
            parameters=[pb.ParameterValue(name=n, value=v) for n, v in items],
            warmup=warmup, duration=duration, seed=seed, trajectory_period=trajectory_period,
            time_step=time_step, motor_defects=defects,
            module_defects=[pb.SetModuleDefectRequest(module_id=m, defective=True)
                            for m in module_defects],
            upside_down=upside_down)
        if friction is not None:
            request.ground.friction = friction
        if slope is not None:
            request.ground.slope = slope
        if slope_direction is not None:
            request.ground.slope_direction = slope_direction
        simulated = (warmup or 8.0) + (duration or 12.0)
        extra = simulated if math.isfinite(simulated) else 0.0
        if frame_rate:
            request.frames.CopyFrom(pb.EvaluationFrames(
                camera=self._camera(camera, distance, elevation, azimuth, None, None, None, 0.0),
                width=width, height=height, hide_labels=not labels, hide_legend=not legend,
                frame_rate=frame_rate, mp4=mp4, png_frames=list(png_frames)))
            work = simulated * frame_rate * 0.2
            extra += work if math.isfinite(work) else 0.0
        r = self._call("Evaluate", request, timeout, extra)
        return Evaluation(r.velocity, r.distance, _pose(r.final_pose),
                          [TrajectorySample(t.time, _vector(t.position)) for t in r.trajectory],
                          r.diverged, r.divergence, r.wall_seconds,
                          [Frame(f.index, f.time, f.png) for f in r.frames],
                          r.mp4, r.mp4_frames, r.video_note)

    @staticmethod
    def _camera(camera: str, distance: Optional[float], elevation: Optional[float],
                azimuth: Optional[float], eye: Optional[Sequence[float]],
                target: Optional[Sequence[float]], height: Optional[float],
                fov: float) -> pb.Camera:
        kinds = {"follow": pb.CAMERA_FOLLOW, "fixed": pb.CAMERA_FIXED, "top": pb.CAMERA_TOP}
        if camera not in kinds:
            raise ValueError(f"camera {camera!r} is not follow, fixed or top")
        c = pb.Camera(kind=kinds[camera], fov=fov)
        if distance is not None:
            c.distance = distance
        if elevation is not None:
            c.elevation = elevation
        if azimuth is not None:
            c.azimuth = azimuth
        if height is not None:
            c.height = height
        if eye is not None:
            c.eye.CopyFrom(pb.Vector3(x=eye[0], y=eye[1], z=eye[2]))
        if target is not None:
            c.target.CopyFrom(pb.Vector3(x=target[0], y=target[1], z=target[2]))
        return c

    def snapshot(self, path: Optional[Union[str, os.PathLike]] = None, *,
                 camera: str = "follow", width: int = 640, height: int = 480,
                 distance: Optional[float] = None, elevation: Optional[float] = None,
                 azimuth: Optional[float] = None, eye: Optional[Sequence[float]] = None,
                 target: Optional[Sequence[float]] = None,
                 camera_height: Optional[float] = None, fov: float = 0.0,
                 labels: bool = True, legend: bool = True,
                 timeout: Optional[float] = None) -> bytes:
        """A PNG picture of the simulated robot now (RenderFrame); also written
        to ``path`` when given.

        ``camera``: "follow" (distance [m], elevation, azimuth [rad] around the
        central module), "fixed" (eye, target [m]) or "top" (the ceiling camera:
        camera_height [m] above target). Size 1..4096 pixels a side.
        """
        request = pb.RenderFrameRequest(
            camera=self._camera(camera, distance, elevation, azimuth, eye, target,
                                camera_height, fov),
            width=width, height=height, hide_labels=not labels, hide_legend=not legend)
        png = self._call("RenderFrame", request, timeout, extra=20.0).png
        if path is not None:
            with open(path, "wb") as f:
                f.write(png)
        return png

    def frames(self, seconds: float, frame_rate: float = 25.0, *, watch: bool = False,
               camera: str = "follow", width: int = 640, height: int = 480,
               distance: Optional[float] = None, elevation: Optional[float] = None,
               azimuth: Optional[float] = None, eye: Optional[Sequence[float]] = None,
               target: Optional[Sequence[float]] = None,
               camera_height: Optional[float] = None, fov: float = 0.0,
               labels: bool = True, legend: bool = True,
               timeout: Optional[float] = None) -> Iterator[Frame]:
        """Yields round(seconds * frame_rate) frames 1/frame_rate simulated
        seconds apart (RecordFrames), each as soon as it is drawn.

        By default the stream steps the world itself; with ``watch`` it films
        the world while others advance it (free-run, a Sleep). Camera options
        as :meth:`snapshot`. The deadline adds 0.2 s per frame (plus
        ``seconds`` with ``watch``). Pipe the PNGs to ffmpeg for a video, or
        use ``yamorctl record``.
        """
        request = pb.RecordFramesRequest(
            camera=self._camera(camera, distance, elevation, azimuth, eye, target,
                                camera_height, fov),
            width=width, height=height, hide_labels=not labels, hide_legend=not legend,
            frame_rate=frame_rate, seconds=seconds, watch=watch)
        work = seconds * frame_rate * 0.2 + (seconds if watch else 0.0)
        call = self._stub.RecordFrames(
            request, timeout=self._deadline(timeout, work if math.isfinite(work) else 0.0))
        try:
            for f in call:
                yield Frame(f.index, f.time, f.png)
        except grpc.RpcError as e:
            raise HostError(e.code(), e.details() or "", "RecordFrames") from None
        finally:
            call.cancel()

    def health(self, service: str = "", timeout: Optional[float] = None) -> str:
        """grpc.health.v1 status name of the daemon ("SERVING", ...).

        Needs the grpcio-health-checking package.
        """
        from grpc_health.v1 import health_pb2, health_pb2_grpc

        stub = health_pb2_grpc.HealthStub(self._channel)
        try:
            r = stub.Check(health_pb2.HealthCheckRequest(service=service),
                           timeout=self._deadline(timeout))
        except grpc.RpcError as e:
            raise HostError(e.code(), e.details() or "", "Health.Check") from None
        return health_pb2.HealthCheckResponse.ServingStatus.Name(r.status)
