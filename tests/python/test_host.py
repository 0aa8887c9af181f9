"""yamor.Host against a real yamord: the thesis session, every parameter, errors,
Evaluate, WatchState."""

from __future__ import annotations

import math
import shutil
import threading
import time

import pytest

import yamor
from yamor.v1 import host_pb2

# Every RPC of yamor.v1.Host and the wrapper method that calls it.
WRAPPER = {
    "ElapsedTime": "elapsed_time",
    "RobotPosition": "position",
    "SimulationModeEnabled": "simulation_mode_enabled",
    "AddCoupling": "add_coupling",
    "CloseSimulation": "close_simulation",
    "ConnectRobot": "connect",
    "Flush": "flush",
    "GetAllModulesId": "modules",
    "GetCouplingPhase": "phase",
    "SetCouplingPhase": "set_phase",
    "GetCouplingWeight": "weight",
    "SetCouplingWeight": "set_weight",
    "GetModuleAmplitude": "amplitude",
    "SetModuleAmplitude": "set_amplitude",
    "GetModuleMaxAngle": "max_angle",
    "SetModuleMaxAngle": "set_max_angle",
    "GetModuleMinAngle": "min_angle",
    "SetModuleMinAngle": "set_min_angle",
    "GetModuleOffset": "offset",
    "SetModuleOffset": "set_offset",
    "GetModuleSpeed": "speed",
    "SetModuleSpeed": "set_speed",
    "OpenSimulation": "open_simulation",
    "Refresh": "refresh",
    "RemoveAllCoupling": "remove_all_couplings",
    "SendControlMessage": "control",
    "Sleep": "sleep",
    "GetInfo": "info",
    "LoadConfig": "load_config",
    "SaveConfig": "save_config",
    "GetMorphology": "morphology",
    "ConnectModules": "connect_modules",
    "DisconnectModule": "disconnect_module",
    "RunTransformationScript": "run_script",
    "SetMotorDefect": "set_motor_defect",
    "SetModuleDefect": "set_module_defect",
    "SetGround": "set_ground",
    "GetServoAngles": "servo_angles",
    "GetAccelerometer": "accelerometer",
    "GetOrientation": "orientation",
    "ResetSimulation": "reset",
    "TurnUpsideDown": "turn_upside_down",
    "WatchState": "watch",
    "Evaluate": "evaluate",
    "SetFreeRun": "set_free_run",
    "RenderFrame": "snapshot",
    "RecordFrames": "frames",
    "SimulatedPosition": "simulated_position",
}


def wait_until(predicate, timeout: float = 10.0) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if predicate():
            return True
        time.sleep(0.01)
    return predicate()


def planar_distance(a: yamor.Position, b: yamor.Position) -> float:
    return math.hypot(b.x - a.x, b.y - a.y)


def test_wrapper_covers_every_rpc():
    rpcs = {m.name for m in host_pb2.DESCRIPTOR.services_by_name["Host"].methods}
    assert rpcs == set(WRAPPER), "update WRAPPER and yamor.Host for the changed API"
    for method in WRAPPER.values():
        assert callable(getattr(yamor.Host, method)), method


def test_info_and_health(host):
    info = host.info()
    assert info.version
    assert info.backend == "simulation"
    assert info.worker_capacity >= 1
    assert "quadruped" in info.builtin_worlds
    assert host.health() == "SERVING"


def test_modules_of_the_default_world(fresh):
    ids = fresh.modules()
    assert ids == sorted(ids) and len(ids) == 9  # the quadruped: 4 hips, 4 knees, a body
    assert fresh.simulation_mode_enabled()
    assert fresh.morphology().central_module in ids
    assert "<morphology" in fresh.morphology().xml


def test_thesis_session_moves_the_robot(host):
    # Thesis 5.5: open the default world, connect, switch everything on, let it walk.
    host.set_free_run(0)
    opened = host.open_simulation()
    assert opened.central_module in opened.module_ids
    assert host.elapsed_time() == 0.0
    start = host.position()
    assert start.source == "simulation"
    connected = host.connect()
    assert connected.links == len(opened.module_ids) - 1  # a tree
    assert connected.frames_sent > connected.links      # links plus configuration
    assert host.info().connected
    host.control(uart=True, cpg=True, motors=True)
    assert host.sleep(20) == pytest.approx(20.0, abs=0.01)
    assert host.elapsed_time() == pytest.approx(20.0, abs=0.01)
    end = host.position()
    assert end.time == pytest.approx(20.0, abs=0.01)
    truth = host.simulated_position()  # the same pose without a tracker
    assert truth.source == "simulation" and (truth.x, truth.y, truth.time) == (end.x, end.y, end.time)
    assert planar_distance(start, end) > 0.05, f"robot did not walk: {start} -> {end}"
    angles = host.servo_angles()
    assert set(angles) == set(opened.module_ids)
    assert any(abs(a) > 0.05 for a in angles.values())
    samples = host.accelerometer(opened.module_ids[0], samples=3)  # UART is on
    assert len(samples) == 3
    upright = host.orientation(opened.module_ids[0])
    assert upright.samples == 16 and not upright.upside_down
    # Reset returns to time 0 at the start pose.
    host.reset()
    assert host.elapsed_time() == 0.0
    assert planar_distance(start, host.position()) < 1e-6


def test_module_parameters_round_trip(fresh):
    for getter, setter, value in [("amplitude", "set_amplitude", 0.5),
                                  ("offset", "set_offset", -0.25),
                                  ("speed", "set_speed", 0.75),
                                  ("min_angle", "set_min_angle", -0.5),
                                  ("max_angle", "set_max_angle", 0.6)]:
        getattr(fresh, setter)(3, value)
        assert getattr(fresh, getter)(3) == value, getter
    assert f'amplitude="0.5"' in fresh.save_config()
    fresh.connect()
    assert fresh.refresh() > 0


def test_coupling_parameters_round_trip(fresh):
    fresh.add_coupling(0, 2, 0.3, 0.7)
    assert fresh.phase(0, 2) == 0.3
    assert fresh.weight(0, 2) == 0.7
    fresh.set_phase(0, 2, 1.57)
    fresh.set_weight(0, 2, 0.25)
    assert (fresh.phase(0, 2), fresh.weight(0, 2)) == (1.57, 0.25)
    fresh.remove_all_couplings()
    with pytest.raises(yamor.HostError) as e:
        fresh.phase(0, 2)
    assert e.value.code == "NOT_FOUND"


def test_config_save_load_round_trip(fresh):
    fresh.set_amplitude(1, 0.123)
    xml = fresh.save_config()
    fresh.open_simulation(world="quadruped")  # back to the built-in configuration
    assert fresh.amplitude(1) != 0.123
    fresh.load_config(xml, "saved.xml")
    assert fresh.amplitude(1) == 0.123


@pytest.mark.parametrize("call, code", [
    (lambda h: h.amplitude(42), "NOT_FOUND"),
    (lambda h: h.set_speed(42, 1.0), "NOT_FOUND"),
    (lambda h: h.set_amplitude(3, float("nan")), "INVALID_ARGUMENT"),
    (lambda h: h.set_offset(3, float("inf")), "INVALID_ARGUMENT"),
    (lambda h: h.set_phase(0, 1, float("nan")), "INVALID_ARGUMENT"),
    (lambda h: h.set_max_angle(3, -3.0), "OUT_OF_RANGE"),
    (lambda h: h.load_config("<yamorconfig", "broken.xml"), "INVALID_ARGUMENT"),
    (lambda h: h.open_simulation(world="no-such-world"), "NOT_FOUND"),
    (lambda h: h.evaluate({"bogus.1": 1.0}), "INVALID_ARGUMENT"),
    (lambda h: h.accelerometer(0, samples=17), "OUT_OF_RANGE"),
    (lambda h: h.orientation(0, samples=17), "OUT_OF_RANGE"),
    (lambda h: h.sleep(-1.0), "OUT_OF_RANGE"),
])
def test_errors_raise_host_error_and_the_daemon_survives(fresh, call, code):
    with pytest.raises(yamor.HostError) as e:
        call(fresh)
    assert e.value.code == code, e.value
    assert e.value.message
    assert e.value.code_number == e.value.status.value[0]
    assert fresh.info().version  # still serving


def test_nan_message_and_code_number(fresh):
    with pytest.raises(yamor.HostError) as e:
        fresh.set_amplitude(3, float("nan"))
    assert (e.value.code, e.value.code_number) == ("INVALID_ARGUMENT", 3)
    assert "nan" in e.value.message
    with pytest.raises(yamor.HostError) as e:
        fresh.amplitude(42)
    assert (e.value.code, e.value.code_number) == ("NOT_FOUND", 5)
    assert "42" in e.value.message and str(e.value).startswith("NOT_FOUND: ")


def test_no_simulation_is_failed_precondition(host):
    host.set_free_run(0)
    host.close_simulation()
    assert not host.simulation_mode_enabled()
    with pytest.raises(yamor.HostError) as e:
        host.position()
    assert e.value.code == "FAILED_PRECONDITION"
    host.open_simulation()


def test_every_call_has_a_deadline(fresh):
    with pytest.raises(yamor.HostError) as e:
        fresh.sleep(30, real_time=True, timeout=0.3)
    assert e.value.code == "DEADLINE_EXCEEDED"
    assert fresh.info().version  # the daemon noticed the cancellation and serves on


def test_unreachable_daemon_is_unavailable():
    with yamor.Host("127.0.0.1:1", timeout=5.0) as h:
        with pytest.raises(yamor.HostError) as e:
            h.info()
    assert e.value.code == "UNAVAILABLE"


def test_faults_ground_and_reconfiguration(fresh):
    fresh.set_motor_defect(5, "limp")
    fresh.set_motor_defect(5, "ok")
    fresh.set_module_defect(6, True)
    fresh.set_module_defect(6, False)
    fresh.set_ground(friction=0.8, slope=0.05)
    fresh.disconnect_module(7)
    fresh.connect_modules(7, "front", 5, "rear", 0)
    assert 'idfrom="7"' in fresh.morphology().xml
    with pytest.raises(ValueError):
        fresh.set_motor_defect(5, "melted")


def test_evaluate_is_deterministic(fresh):
    params = {"amplitude.0": 0.6, "phase.0.1": 1.2}
    a = fresh.evaluate(params, seed=5, warmup=2, duration=4, trajectory_period=1.0)
    b = fresh.evaluate(params, seed=5, warmup=2, duration=4, trajectory_period=1.0)
    assert not a.diverged
    assert a.velocity == b.velocity and a.distance == b.distance
    assert a.final_pose == b.final_pose
    assert a.velocity == pytest.approx(a.distance / 4)
    assert [t.time for t in a.trajectory] == pytest.approx([0, 1, 2, 3, 4, 5, 6])
    c = fresh.evaluate({"amplitude.0": 0.1}, seed=5, warmup=2, duration=4)
    assert c.velocity != a.velocity
    # Evaluate is stateless: the daemon's world did not move.
    assert fresh.elapsed_time() == 0.0


def test_a_filmed_evaluation_returns_its_frames(fresh):
    plain = fresh.evaluate(seed=5, warmup=0.5, duration=1)
    filmed = fresh.evaluate(seed=5, warmup=0.5, duration=1, frame_rate=4, width=40, height=30,
                            legend=False)
    assert plain.frames == []
    assert filmed.velocity == plain.velocity  # filming changes nothing
    assert [f.index for f in filmed.frames] == list(range(6))
    assert [f.time for f in filmed.frames] == pytest.approx([0, 0.25, 0.5, 0.75, 1.0, 1.25])
    for f in filmed.frames:
        assert f.png[:8] == b"\x89PNG\r\n\x1a\n"
        assert int.from_bytes(f.png[16:20], "big") == 40 and int.from_bytes(f.png[20:24], "big") == 30
    with pytest.raises(yamor.HostError) as e:
        fresh.evaluate(seed=5, warmup=0.5, duration=1, frame_rate=4, width=0)
    assert e.value.code == "OUT_OF_RANGE" and "frame width 0" in str(e.value)
    with pytest.raises(yamor.HostError) as e:
        fresh.evaluate(seed=5, warmup=0.5, duration=1, frame_rate=4, distance=math.nan)
    assert e.value.code == "INVALID_ARGUMENT" and "camera distance is not finite" in str(e.value)
    assert fresh.elapsed_time() == 0.0


@pytest.mark.skipif(shutil.which("ffmpeg") is None, reason="ffmpeg not installed")
def test_a_filmed_evaluation_as_one_mp4_made_by_the_daemon(fresh):
    pngs = fresh.evaluate(seed=5, warmup=0.5, duration=1, frame_rate=4, width=40, height=30)
    film = fresh.evaluate(seed=5, warmup=0.5, duration=1, frame_rate=4, width=40, height=30,
                          mp4=True, png_frames=[5, 2])
    assert film.velocity == pngs.velocity
    assert film.mp4[4:8] == b"ftyp" and film.mp4_frames == 6 and film.video_note == ""
    assert [f.index for f in film.frames] == [2, 5]
    assert [f.png for f in film.frames] == [pngs.frames[2].png, pngs.frames[5].png]
    with pytest.raises(yamor.HostError) as e:
        fresh.evaluate(seed=5, warmup=0.5, duration=1, frame_rate=4, mp4=True, png_frames=[6])
    assert e.value.code == "OUT_OF_RANGE" and "PNG frame 6 is past the film's 6 frames" in str(e.value)


def test_evaluate_takes_the_robots_condition(fresh):
    healthy = fresh.evaluate(seed=5, warmup=1, duration=2)
    for condition in ({"motor_defects": {2: "limp"}}, {"module_defects": [3]},
                      {"friction": 0.05}, {"upside_down": True}):
        changed = fresh.evaluate(seed=5, warmup=1, duration=2, **condition)
        assert changed.velocity != healthy.velocity, condition
    with pytest.raises(yamor.HostError) as error:
        fresh.evaluate(seed=5, warmup=1, duration=2, module_defects=[99])
    assert error.value.code == "NOT_FOUND" and "module 99" in error.value.message
    with pytest.raises(yamor.HostError) as error:
        fresh.evaluate(seed=5, warmup=1, duration=2, slope=2.0)
    assert error.value.code == "OUT_OF_RANGE"
    with pytest.raises(ValueError):
        fresh.evaluate(motor_defects={2: "melted"})


def test_watch_yields_updates_and_events(fresh):
    fresh.connect()
    fresh.control(uart=True, cpg=True, motors=True)
    updates: list = []
    failure: list = []

    def consume():
        try:
            for update in fresh.watch(period=0.5, count=5, timeout=60):
                updates.append(update)
        except Exception as e:  # reported below
            failure.append(e)

    watcher = threading.Thread(target=consume)
    watcher.start()
    assert wait_until(lambda: updates or failure), "no first update"  # sent at once
    fresh.set_motor_defect(3, "limp")
    fresh.sleep(3)
    watcher.join(timeout=60)
    assert not watcher.is_alive()
    assert not failure, failure
    assert len(updates) == 5
    times = [u.time for u in updates]
    assert times == sorted(times) and times[-1] - times[0] >= 1.5
    assert any(e.kind == "defect_set" and e.module_id == 3 for u in updates for e in u.events)
    assert any(math.hypot(*u.velocity[:2]) > 0 for u in updates[1:])


def test_free_run_advances_time(fresh):
    fresh.set_free_run(20)
    try:
        assert wait_until(lambda: fresh.elapsed_time() > 0.2, timeout=20)
    finally:
        fresh.set_free_run(0)
    assert fresh.info().free_run_factor == 0


def test_transformation_script(fresh, tmp_path):
    script = tmp_path / "script.xml"
    script.write_text('<script><disconnect id="8"/><pause delay="100"/>'
                      '<connect idfrom="8" connfrom="front" idto="6" connto="rear" angle="0"/>'
                      '</script>')
    fresh.run_script_file(script)
    assert 'idfrom="8"' in fresh.morphology().xml


def test_thesis_session_rolls_the_wheel(fresh):
    # Appendix A.4 through the interactive path: "everything on" powers the
    # three active modules only; the inactive corners stay free, so it rolls.
    fresh.set_free_run(0)
    fresh.open_simulation(world="wheel")
    start = fresh.position()
    fresh.connect()
    fresh.control(uart=True, cpg=True, motors=True)
    fresh.sleep(20)
    travelled = planar_distance(start, fresh.position())
    assert travelled > 1.0, f"the wheel did not roll: {travelled:.3f} m in 20 s"
    fresh.open_simulation(world="quadruped")  # back to the default robot


def test_snapshot_is_a_png_of_the_robot_and_changes_nothing(fresh, tmp_path):
    before = fresh.elapsed_time()
    path = tmp_path / "robot.png"
    png = fresh.snapshot(path, width=320, height=240)
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and path.read_bytes() == png
    assert int.from_bytes(png[16:20], "big") == 320 and int.from_bytes(png[20:24], "big") == 240
    assert fresh.snapshot(width=320, height=240) == png  # same state, same bytes
    top = fresh.snapshot(camera="top", camera_height=1.5, width=64, height=48, legend=False)
    assert top != png
    assert fresh.elapsed_time() == before


@pytest.mark.parametrize("kwargs, code", [
    (dict(width=0), "OUT_OF_RANGE"),
    (dict(height=5000), "OUT_OF_RANGE"),
    (dict(azimuth=math.nan), "INVALID_ARGUMENT"),
    (dict(camera="fixed", eye=(0, 0, 0), target=(0, 0, 0)), "INVALID_ARGUMENT"),
])
def test_bad_frames_are_refused_and_the_daemon_serves_on(fresh, kwargs, code):
    with pytest.raises(yamor.HostError) as e:
        fresh.snapshot(**kwargs)
    assert e.value.code == code
    assert fresh.elapsed_time() == 0.0


def test_frames_step_the_world_and_come_at_the_rate(fresh):
    frames = list(fresh.frames(0.4, 10, width=64, height=48))
    assert [f.index for f in frames] == [0, 1, 2, 3]
    assert [round(f.time, 6) for f in frames] == [0.0, 0.1, 0.2, 0.3]
    assert all(f.png[:4] == b"\x89PNG" for f in frames)
    assert abs(fresh.elapsed_time() - 0.4) < 1e-9
    with pytest.raises(yamor.HostError) as e:
        list(fresh.frames(1.0, 0))
    assert e.value.code == "OUT_OF_RANGE"
