"""One soak client process: THREADS clients hammering one yamord.

Started by yamor.tools.soak (``python -m yamor.tools.soak_client ADDRESS --threads N
--seed S``); the driver SIGKILLs some of these processes mid-stream and starts
new ones.

Each client thread has its own channel (its own connection: a local
subchannel pool) and loops over ACTIONS, picked at random by weight from a
random.Random seeded from --seed and the thread's index: valid and invalid
unary calls of every RPC of yamor.v1.Host, Evaluate batches (some cancelled
half-way), WatchState and RecordFrames streams opened and dropped, channels
closed under open streams. Every call has a deadline.

Reports go to stdout, one JSON object a line, every REPORT_PERIOD seconds:
{"counts": {"Rpc CODE": n, ...}, "open": streams open now, "bad": [...]}.
Counts are deltas since the previous line; "bad" holds a few messages of
codes the daemon must never send (INTERNAL, UNKNOWN, DATA_LOSS). CODE is a
gRPC status name, or DROPPED for a call this client cancelled itself.
SIGTERM: finish the current action, print the last line, exit 0.
"""

from __future__ import annotations

import argparse
import json
import random
import signal
import sys
import threading
import time
from collections import Counter
from typing import Callable, Dict, List, Optional

# Stop requests may come while grpc is still being imported: remember them
# from the start (main() turns the flag into its stop event).
_EARLY_STOP = threading.Event()
if __name__ == "__main__":  # not when imported (tests)
    signal.signal(signal.SIGTERM, lambda *_: _EARLY_STOP.set())

import grpc  # noqa: E402  (after the handler: importing grpc takes a while)
from google.protobuf import empty_pb2  # noqa: E402

from yamor.v1 import host_pb2 as pb  # noqa: E402
from yamor.v1 import host_pb2_grpc as pb_grpc  # noqa: E402

REPORT_PERIOD = 0.5
CALL_DEADLINE = 30.0   # seconds; unary calls (the daemon may be under ASan on a busy machine)
STREAM_DEADLINE = 20.0
BAD_CODES = ("INTERNAL", "UNKNOWN", "DATA_LOSS")

# The quadruped's real module ids (the default world); anything else is unknown.
MODULES = list(range(9))
UNKNOWN_MODULES = [42, 254, 255, 4294967295]
NAN = float("nan")
INF = float("inf")

GOOD_SCRIPT = ('<script><disconnect id="8"/><pause delay="50"/>'
               '<connect idfrom="8" connfrom="front" idto="6" connto="rear" angle="0"/></script>')
BAD_SCRIPTS = ["<script", "<script><explode id=\"1\"/></script>",
               '<script><disconnect id="42"/></script>',
               '<script><pause delay="-5"/></script>', ""]
BAD_XML = ["<yamorconfig", "<robot><module id='x'/></robot>", "\x00\xff garbage", "<a>" * 200]


class Recorder:
    """Counts of (rpc, code) and a few messages of bad codes; thread-safe."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._counts: Counter = Counter()
        self._bad: List[str] = []
        self.open_streams = 0

    def record(self, rpc: str, code: str, detail: str = "") -> None:
        with self._lock:
            self._counts[f"{rpc} {code}"] += 1
            if code in BAD_CODES and len(self._bad) < 20:
                self._bad.append(f"{rpc} {code}: {detail}")

    def streams(self, delta: int) -> None:
        with self._lock:
            self.open_streams += delta

    def take(self) -> dict:
        with self._lock:
            out = {"counts": dict(self._counts), "open": self.open_streams, "bad": self._bad}
            self._counts = Counter()
            self._bad = []
            return out


class Client:
    """One client: its channel, stub, random source and recorder."""

    def __init__(self, address: str, rng: random.Random, recorder: Recorder,
                 stop: threading.Event) -> None:
        self.address = address
        self.rng = rng
        self.rec = recorder
        self.stop = stop
        self.channel: Optional[grpc.Channel] = None
        self.stub: Optional[pb_grpc.HostStub] = None
        self.reconnect()

    def reconnect(self) -> None:
        if self.channel is not None:
            self.channel.close()
        self.channel = grpc.insecure_channel(self.address, options=[
            ("grpc.use_local_subchannel_pool", 1),  # a connection of its own
            ("grpc.max_receive_message_length", 64 << 20)])
        self.stub = pb_grpc.HostStub(self.channel)

    # ---- calls ----------------------------------------------------------------

    def unary(self, rpc: str, request, timeout: float = CALL_DEADLINE):
        try:
            response = getattr(self.stub, rpc)(request, timeout=timeout)
        except grpc.RpcError as e:
            self.rec.record(rpc, e.code().name, e.details() or "")
            self.back_off(e.code())
            return None
        self.rec.record(rpc, "OK")
        return response

    def back_off(self, code: grpc.StatusCode) -> None:
        """After RESOURCE_EXHAUSTED a client waits a little, as the daemon asks ("retry later")."""
        if code == grpc.StatusCode.RESOURCE_EXHAUSTED:
            self.stop.wait(self.rng.uniform(0.05, 0.3))

    def stream(self, rpc: str, request, drop_after: float, max_items: int,
               read: bool = True, close_channel: bool = False) -> None:
        """Opens a server stream, reads up to max_items (or none), drops it after drop_after s."""
        dropped = threading.Event()
        call = getattr(self.stub, rpc)(request, timeout=STREAM_DEADLINE)

        def drop() -> None:
            dropped.set()
            if close_channel:
                self.channel.close()  # the connection goes with the stream
            else:
                call.cancel()

        timer = threading.Timer(drop_after, drop)
        timer.start()
        self.rec.streams(+1)
        try:
            if read:
                received = 0
                for _ in call:
                    received += 1
                    if received >= max_items:
                        drop()
                        break
            else:
                dropped.wait(timeout=STREAM_DEADLINE)
            if dropped.is_set():
                self.rec.record(rpc, "DROPPED")
            else:
                self.rec.record(rpc, "OK")  # the daemon ended it (shutdown)
        except grpc.RpcError as e:
            code = e.code().name
            self.rec.record(rpc, "DROPPED" if dropped.is_set() and code == "CANCELLED" else code,
                            e.details() or "")
            self.back_off(e.code())
        except ValueError:
            # A closed channel can surface as ValueError from the iterator.
            self.rec.record(rpc, "DROPPED")
        finally:
            timer.cancel()
            self.rec.streams(-1)
            if close_channel:
                timer.join()
                self.reconnect()

    # ---- helpers for requests -------------------------------------------------

    def module(self, valid: bool) -> int:
        return self.rng.choice(MODULES) if valid else self.rng.choice(UNKNOWN_MODULES)

    def bad_number(self) -> float:
        return self.rng.choice([NAN, INF, -INF, -1e308, 1e308])

    def valid(self, p: float = 0.6) -> bool:
        return self.rng.random() < p


EMPTY = empty_pb2.Empty()

# ---- actions: (weight, RPCs it calls, function) ------------------------------------

Action = Callable[[Client], None]
ACTIONS: List[tuple] = []


def action(weight: float, *rpcs: str):
    def register(fn: Action) -> Action:
        ACTIONS.append((weight, rpcs, fn))
        return fn
    return register


@action(12, "ElapsedTime", "RobotPosition", "SimulatedPosition", "SimulationModeEnabled",
        "GetInfo", "GetAllModulesId", "SaveConfig", "GetMorphology")
def empty_getter(c: Client) -> None:
    rpc = c.rng.choice(["ElapsedTime", "RobotPosition", "SimulatedPosition",
                        "SimulationModeEnabled", "GetInfo", "GetAllModulesId", "SaveConfig",
                        "GetMorphology"])
    c.unary(rpc, EMPTY)


_MODULE_PARAMS = {  # name: (getter, setter, valid value range)
    "amplitude": ("GetModuleAmplitude", "SetModuleAmplitude", (0.0, 0.8)),
    "offset": ("GetModuleOffset", "SetModuleOffset", (-0.3, 0.3)),
    "speed": ("GetModuleSpeed", "SetModuleSpeed", (0.2, 1.5)),
    "min": ("GetModuleMinAngle", "SetModuleMinAngle", (-1.5, -0.6)),
    "max": ("GetModuleMaxAngle", "SetModuleMaxAngle", (0.6, 1.5)),
}


@action(14, *[r for g, s, _ in _MODULE_PARAMS.values() for r in (g, s)])
def module_parameter(c: Client) -> None:
    getter, setter, (low, high) = _MODULE_PARAMS[c.rng.choice(list(_MODULE_PARAMS))]
    if c.rng.random() < 0.5:
        c.unary(getter, pb.ModuleRequest(module_id=c.module(c.valid(0.8))))
        return
    if c.valid():
        value = c.rng.uniform(low, high)
        module = c.module(True)
    else:
        value, module = c.rng.choice([(c.bad_number(), c.module(True)),
                                      (-3.5, c.module(True)),  # negative or beyond a limit
                                      (3.5, c.module(True)),
                                      (c.rng.uniform(low, high), c.module(False))])
    c.unary(setter, pb.SetModuleValueRequest(module_id=module, value=value))


@action(8, "AddCoupling", "GetCouplingPhase", "SetCouplingPhase", "GetCouplingWeight",
        "SetCouplingWeight", "RemoveAllCoupling")
def coupling(c: Client) -> None:
    a, b = c.rng.sample(MODULES, 2)
    if not c.valid():
        a = c.rng.choice([a, c.module(False)])
    roll = c.rng.random()
    if roll < 0.3:
        phase = c.rng.uniform(-3, 3) if c.valid(0.8) else c.bad_number()
        c.unary("AddCoupling", pb.AddCouplingRequest(from_id=a, to_id=b, phase=phase,
                                                     weight=c.rng.uniform(0, 1)))
    elif roll < 0.55:
        c.unary(c.rng.choice(["GetCouplingPhase", "GetCouplingWeight"]),
                pb.CouplingRequest(from_id=a, to_id=b))
    elif roll < 0.95:
        value = c.rng.uniform(0, 1) if c.valid(0.8) else c.bad_number()
        c.unary(c.rng.choice(["SetCouplingPhase", "SetCouplingWeight"]),
                pb.SetCouplingValueRequest(from_id=a, to_id=b, value=value))
    else:
        c.unary("RemoveAllCoupling", EMPTY)


@action(6, "ConnectRobot", "Flush", "Refresh", "SendControlMessage")
def robot_link(c: Client) -> None:
    roll = c.rng.random()
    if roll < 0.2:
        timeout = c.rng.choice([0.0, 0.5]) if c.valid(0.8) else c.rng.choice([-1.0, NAN, 1e9])
        c.unary("ConnectRobot", pb.ConnectRobotRequest(link_timeout=timeout,
                                                       links_only=c.rng.random() < 0.3))
    elif roll < 0.5:
        c.unary(c.rng.choice(["Flush", "Refresh"]), EMPTY)
    else:
        on = pb.SWITCH_ON
        if c.valid():
            request = pb.ControlMessageRequest(uart=on, cpg=on, motors=on, all=True)
        else:
            request = c.rng.choice([
                pb.ControlMessageRequest(uart=on, module_ids=[c.module(False)]),
                pb.ControlMessageRequest(cpg=7),  # not a Switch value
                pb.ControlMessageRequest(motors=on, module_ids=[1], all=True)])
        c.unary("SendControlMessage", request)


@action(8, "Sleep")
def sleep(c: Client) -> None:
    if c.valid(0.85):
        request = pb.SleepRequest(seconds=c.rng.uniform(0.01, 0.3),
                                  real_time=c.rng.random() < 0.1)
    else:
        request = pb.SleepRequest(seconds=c.rng.choice([-1.0, NAN, INF]))
    c.unary("Sleep", request)


@action(1.5, "OpenSimulation", "CloseSimulation", "ResetSimulation", "TurnUpsideDown")
def world(c: Client) -> None:
    roll = c.rng.random()
    if roll < 0.4:
        if c.valid(0.7):
            request = pb.OpenSimulationRequest(world=c.rng.choice(["quadruped"] * 4 + ["snake"]),
                                               seed=c.rng.randrange(1 << 32))
        else:
            request = c.rng.choice([
                pb.OpenSimulationRequest(world="no-such-world"),
                pb.OpenSimulationRequest(morphology_xml=c.rng.choice(BAD_XML)),
                pb.OpenSimulationRequest(world="quadruped", config_xml=c.rng.choice(BAD_XML)),
                pb.OpenSimulationRequest(world="quadruped", time_step=c.bad_number())])
        c.unary("OpenSimulation", request)
    elif roll < 0.45:
        c.unary("CloseSimulation", EMPTY)
    elif roll < 0.8:
        c.unary("ResetSimulation", EMPTY)
    else:
        c.unary("TurnUpsideDown", EMPTY)


@action(3, "SaveConfig", "LoadConfig")
def config(c: Client) -> None:
    if c.valid(0.5):
        saved = c.unary("SaveConfig", EMPTY)
        xml = saved.config_xml if saved is not None else ""
    else:
        xml = c.rng.choice(BAD_XML)
    c.unary("LoadConfig", pb.LoadConfigRequest(config_xml=xml, source_name="soak.xml"))


@action(3, "ConnectModules", "DisconnectModule", "RunTransformationScript")
def reconfigure(c: Client) -> None:
    roll = c.rng.random()
    if roll < 0.35:
        c.unary("DisconnectModule", pb.ModuleRequest(module_id=c.module(c.valid(0.7))))
    elif roll < 0.7:
        if c.valid():
            request = pb.ConnectModulesRequest(from_id=7, from_connector=pb.CONNECTOR_FRONT,
                                               to_id=5, to_connector=pb.CONNECTOR_REAR)
        else:
            request = pb.ConnectModulesRequest(
                from_id=c.rng.choice([7, 42]), from_connector=c.rng.choice([0, 17]),
                to_id=c.rng.choice([5, 7, 255]), to_connector=pb.CONNECTOR_REAR,
                angle_degrees=c.rng.choice([7.0, NAN, 360.0, -15.0]))
        c.unary("ConnectModules", request)
    else:
        script = GOOD_SCRIPT if c.valid(0.5) else c.rng.choice(BAD_SCRIPTS)
        c.unary("RunTransformationScript", pb.RunTransformationScriptRequest(script_xml=script),
                timeout=CALL_DEADLINE)


@action(4, "SetMotorDefect", "SetModuleDefect", "SetGround")
def faults(c: Client) -> None:
    roll = c.rng.random()
    if roll < 0.35:
        defect = c.rng.choice([pb.MOTOR_OK, pb.MOTOR_OK, pb.MOTOR_LIMP, pb.MOTOR_STUCK])
        if not c.valid():
            defect = c.rng.choice([defect, 99])
        c.unary("SetMotorDefect", pb.SetMotorDefectRequest(module_id=c.module(c.valid(0.8)),
                                                           defect=defect))
    elif roll < 0.7:
        c.unary("SetModuleDefect", pb.SetModuleDefectRequest(
            module_id=c.module(c.valid(0.8)), defective=c.rng.random() < 0.3))
    else:
        request = pb.SetGroundRequest()
        if c.valid():
            request.friction = c.rng.uniform(0.3, 1.0)
            request.slope = c.rng.uniform(0.0, 0.1)
        else:
            which = c.rng.choice(["friction", "slope", "slope_direction"])
            setattr(request, which, c.rng.choice([NAN, -1.0, 2.0, 1e6]))
        c.unary("SetGround", request)


@action(6, "GetServoAngles", "GetAccelerometer", "GetOrientation")
def sensors(c: Client) -> None:
    roll = c.rng.random()
    if roll < 0.4:
        ids = c.rng.sample(MODULES, c.rng.randint(0, 4))
        if not c.valid():
            ids.append(c.module(False))
        c.unary("GetServoAngles", pb.GetServoAnglesRequest(module_ids=ids))
    else:
        samples = c.rng.randint(0, 16) if c.valid() else c.rng.choice([17, 4294967295])
        module = c.module(c.valid(0.8))
        if roll < 0.7:
            c.unary("GetAccelerometer", pb.GetAccelerometerRequest(module_id=module,
                                                                   samples=samples))
        else:
            up = pb.Vector3(x=0, y=0, z=1) if c.valid(0.8) else pb.Vector3(x=NAN)
            c.unary("GetOrientation", pb.GetOrientationRequest(module_id=module, samples=samples,
                                                               reference_up=up))


@action(1, "SetFreeRun")
def free_run(c: Client) -> None:
    # Mostly off: a free-running world at a high factor would eat the machine.
    if c.valid(0.8):
        factor = c.rng.choice([0.0, 0.0, 0.0, 1.0, 2.0])
    else:
        factor = c.rng.choice([-1.0, 101.0, NAN, INF])
    c.unary("SetFreeRun", pb.SetFreeRunRequest(real_time_factor=factor))


def _small_camera(c: Client, valid: bool) -> pb.Camera:
    if valid:
        return pb.Camera(kind=c.rng.choice([pb.CAMERA_FOLLOW, pb.CAMERA_TOP]))
    return c.rng.choice([pb.Camera(azimuth=NAN),
                         pb.Camera(kind=pb.CAMERA_FIXED, eye=pb.Vector3(), target=pb.Vector3()),
                         pb.Camera(fov=-1.0)])


@action(1.5, "RenderFrame", "RecordFrames")
def frames(c: Client) -> None:
    valid = c.valid()
    size = (32, 24) if valid else c.rng.choice([(0, 24), (32, 5000), (4097, 1)])
    if c.rng.random() < 0.5:
        c.unary("RenderFrame", pb.RenderFrameRequest(camera=_small_camera(c, valid or c.valid()),
                                                     width=size[0], height=size[1]))
    else:
        request = pb.RecordFramesRequest(
            camera=_small_camera(c, True), width=size[0], height=size[1],
            frame_rate=10.0 if valid else c.rng.choice([0.0, 241.0, NAN]),
            seconds=c.rng.uniform(0.1, 0.5), watch=c.rng.random() < 0.3)
        c.stream("RecordFrames", request, drop_after=c.rng.uniform(0.1, 2.0),
                 max_items=c.rng.randint(1, 5))


@action(8, "WatchState")
def watch(c: Client) -> None:
    period = c.rng.choice([0.0, 0.02, 0.1, 0.5]) if c.valid(0.85) else c.rng.choice(
        [-1.0, NAN, 1e9])
    roll = c.rng.random()
    c.stream("WatchState", pb.WatchStateRequest(period=period),
             drop_after=c.rng.uniform(0.1, 3.0), max_items=c.rng.randint(1, 40),
             read=roll >= 0.2,              # a fifth never read what they asked for
             close_channel=roll >= 0.9)     # a tenth lose their connection under the stream


_PARAMS = ([f"amplitude.{m}" for m in MODULES] + [f"offset.{m}" for m in MODULES] +
           [f"speed.{m}" for m in MODULES] + ["phase.0.1", "weight.0.1", "phase.2.5"])


def _evaluate_request(c: Client, valid: bool, long: bool = False) -> pb.EvaluateRequest:
    request = pb.EvaluateRequest(
        warmup=c.rng.uniform(0.1, 0.5), duration=600.0 if long else c.rng.uniform(0.2, 1.0),
        seed=c.rng.randrange(1 << 32),
        trajectory_period=c.rng.choice([0.0, 0.0, 0.1]),
        parameters=[pb.ParameterValue(name=n, value=c.rng.uniform(0.0, 0.6))
                    for n in c.rng.sample(_PARAMS, c.rng.randint(0, 5))])
    if valid:
        if c.rng.random() < 0.1:
            request.module_defects.add(module_id=3, defective=True)
        if c.rng.random() < 0.1:
            request.ground.friction = 0.4
        return request
    fault = c.rng.randrange(9)
    if fault == 0:
        request.parameters.add(name="bogus.1", value=1.0)
    elif fault == 1:
        request.parameters.add(name="amplitude.0", value=c.bad_number())
    elif fault == 2:
        request.module_defects.add(module_id=99, defective=True)
    elif fault == 3:
        request.ground.slope = 2.0
    elif fault == 4:
        request.world = "no-such-world"
    elif fault == 5:
        request.config_xml = c.rng.choice(BAD_XML)
    elif fault == 6:
        request.warmup = c.rng.choice([-1.0, NAN, 1e9])
    elif fault == 7:
        request.time_step = c.rng.choice([1e-9, 1.0, NAN])
    else:
        request.motor_defects.add(module_id=2, defect=pb.MOTOR_LIMP)
        request.motor_defects.add(module_id=2, defect=pb.MOTOR_STUCK)  # listed twice
    return request


def _finish_future(c: Client, future, cancelled: bool) -> Optional[grpc.StatusCode]:
    """Records the outcome of an Evaluate future; its error code, if any."""
    try:
        future.result()
    except grpc.FutureCancelledError:
        c.rec.record("Evaluate", "DROPPED")
        return grpc.StatusCode.CANCELLED
    except grpc.RpcError as e:
        code = e.code().name
        c.rec.record("Evaluate", "DROPPED" if cancelled and code == "CANCELLED" else code,
                     e.details() or "")
        return e.code()
    c.rec.record("Evaluate", "OK")
    return None


@action(4, "Evaluate")
def evaluate(c: Client) -> None:
    long = c.rng.random() < 0.1  # a long evaluation, dropped half-way
    valid = long or c.valid(0.7)
    future = c.stub.Evaluate.future(_evaluate_request(c, valid, long), timeout=CALL_DEADLINE * 2)
    cancelled = long
    if long:
        c.stop.wait(c.rng.uniform(0.2, 1.5))
        future.cancel()
    c.back_off(_finish_future(c, future, cancelled))


@action(2, "Evaluate")
def evaluate_batch(c: Client) -> None:
    """A batch of 2..8 evaluations at once (an optimizer's generation), some invalid."""
    batch = []
    for _ in range(c.rng.randint(2, 8)):
        request = _evaluate_request(c, c.valid(0.75))
        batch.append(c.stub.Evaluate.future(request, timeout=CALL_DEADLINE * 4))
    cancelled = set()
    if c.rng.random() < 0.3:  # the optimizer gives up on part of the batch
        c.stop.wait(c.rng.uniform(0.05, 1.0))
        for i in c.rng.sample(range(len(batch)), c.rng.randint(1, len(batch))):
            batch[i].cancel()
            cancelled.add(i)
    codes = [_finish_future(c, future, i in cancelled) for i, future in enumerate(batch)]
    if grpc.StatusCode.RESOURCE_EXHAUSTED in codes:
        c.back_off(grpc.StatusCode.RESOURCE_EXHAUSTED)


def covered_rpcs() -> set:
    """Every RPC some action calls."""
    return {rpc for _, rpcs, _ in ACTIONS for rpc in rpcs}


def run_client(address: str, seed: int, recorder: Recorder, stop: threading.Event,
               errors: List[str]) -> None:
    rng = random.Random(seed)
    weights = [w for w, _, _ in ACTIONS]
    functions = [fn for _, _, fn in ACTIONS]
    client = Client(address, rng, recorder, stop)
    try:
        while not stop.is_set():
            fn = rng.choices(functions, weights)[0]
            fn(client)
    except Exception as e:  # a bug of the soak client, not of the daemon: reported
        errors.append(f"client {seed}: {type(e).__name__}: {e}")
        stop.set()
    finally:
        client.channel.close()


def main(argv: Optional[List[str]] = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("address")
    parser.add_argument("--threads", type=int, default=8)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args(argv)

    stop = _EARLY_STOP
    recorder = Recorder()
    errors: List[str] = []
    threads = [threading.Thread(target=run_client,
                                args=(args.address, args.seed * 1000 + i, recorder, stop, errors),
                                daemon=True)
               for i in range(args.threads)]
    for t in threads:
        t.start()

    def report(final: bool = False) -> None:
        line: Dict = recorder.take()
        if final:
            line["final"] = True
        sys.stdout.write(json.dumps(line) + "\n")
        sys.stdout.flush()

    report()  # at once: the driver waits for this line before it starts the clock
    while not stop.wait(REPORT_PERIOD):
        report()
    for t in threads:
        t.join()
    report(final=True)
    for e in errors:
        print(e, file=sys.stderr)
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
