"""The Python stubs shipped in tools/python/yamor/v1 match proto/yamor/v1/*.proto."""

import filecmp
import os
import shutil
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
SHIPPED = REPO / "tools" / "python" / "yamor" / "v1"
GENERATED = ["host_pb2.py", "host_pb2.pyi", "host_pb2_grpc.py",
             "lifelong_pb2.py", "lifelong_pb2.pyi", "lifelong_pb2_grpc.py"]


def test_shipped_stubs_are_up_to_date(tmp_path):
    plugin = os.environ.get("GRPC_PYTHON_PLUGIN", "/usr/bin/grpc_python_plugin")
    if shutil.which("protoc") is None or not Path(plugin).is_file():
        pytest.skip("protoc or grpc_python_plugin missing (Debian protobuf-compiler, "
                    "protobuf-compiler-grpc)")
    subprocess.run([str(REPO / "tools" / "python" / "generate.sh"), str(tmp_path)], check=True)
    for name in GENERATED:
        fresh = tmp_path / "yamor" / "v1" / name
        assert fresh.is_file(), f"generate.sh did not write {name}"
        assert filecmp.cmp(fresh, SHIPPED / name, shallow=False), (
            f"tools/python/yamor/v1/{name} is stale: run tools/python/generate.sh")
    # Every generated file is shipped, nothing else is generated.
    produced = sorted(p.name for p in (tmp_path / "yamor" / "v1").iterdir())
    assert produced == sorted(GENERATED)


def test_stubs_import_and_name_every_rpc():
    from yamor.v1 import host_pb2, host_pb2_grpc

    service = host_pb2.DESCRIPTOR.services_by_name["Host"]
    stub_methods = {m.name for m in service.methods}
    assert {"GetModuleAmplitude", "Evaluate", "WatchState", "SetFreeRun"} <= stub_methods
    assert hasattr(host_pb2_grpc, "HostStub")
    from yamor.v1 import lifelong_pb2, lifelong_pb2_grpc

    life = lifelong_pb2.DESCRIPTOR.services_by_name["Lifelong"]
    assert {m.name for m in life.methods} == {"GetLifeStatus", "WatchLife"}
    assert hasattr(lifelong_pb2_grpc, "LifelongStub")
