from google.protobuf import empty_pb2 as _empty_pb2
from google.protobuf import descriptor as _descriptor
from google.protobuf import message as _message
from typing import ClassVar as _ClassVar, Mapping as _Mapping, Optional as _Optional, Union as _Union

DESCRIPTOR: _descriptor.FileDescriptor

class LifeStatus(_message.Message):
    __slots__ = ["anomalies", "detail", "ema", "ended", "gait", "gaps", "mode", "recalls", "relearn_budget", "relearn_trials", "relearns", "robot", "state", "threshold", "time", "trials", "velocity"]
    ANOMALIES_FIELD_NUMBER: _ClassVar[int]
    DETAIL_FIELD_NUMBER: _ClassVar[int]
    EMA_FIELD_NUMBER: _ClassVar[int]
    ENDED_FIELD_NUMBER: _ClassVar[int]
    GAIT_FIELD_NUMBER: _ClassVar[int]
    GAPS_FIELD_NUMBER: _ClassVar[int]
    MODE_FIELD_NUMBER: _ClassVar[int]
    RECALLS_FIELD_NUMBER: _ClassVar[int]
    RELEARNS_FIELD_NUMBER: _ClassVar[int]
    RELEARN_BUDGET_FIELD_NUMBER: _ClassVar[int]
    RELEARN_TRIALS_FIELD_NUMBER: _ClassVar[int]
    ROBOT_FIELD_NUMBER: _ClassVar[int]
    STATE_FIELD_NUMBER: _ClassVar[int]
    THRESHOLD_FIELD_NUMBER: _ClassVar[int]
    TIME_FIELD_NUMBER: _ClassVar[int]
    TRIALS_FIELD_NUMBER: _ClassVar[int]
    VELOCITY_FIELD_NUMBER: _ClassVar[int]
    anomalies: int
    detail: str
    ema: float
    ended: bool
    gait: int
    gaps: int
    mode: str
    recalls: int
    relearn_budget: int
    relearn_trials: int
    relearns: int
    robot: str
    state: str
    threshold: float
    time: float
    trials: int
    velocity: float
    def __init__(self, state: _Optional[str] = ..., time: _Optional[float] = ..., velocity: _Optional[float] = ..., ema: _Optional[float] = ..., threshold: _Optional[float] = ..., gait: _Optional[int] = ..., anomalies: _Optional[int] = ..., recalls: _Optional[int] = ..., relearns: _Optional[int] = ..., trials: _Optional[int] = ..., gaps: _Optional[int] = ..., detail: _Optional[str] = ..., relearn_trials: _Optional[int] = ..., relearn_budget: _Optional[int] = ..., mode: _Optional[str] = ..., robot: _Optional[str] = ..., ended: bool = ...) -> None: ...

class LifeUpdate(_message.Message):
    __slots__ = ["index", "json", "kind", "status", "time"]
    INDEX_FIELD_NUMBER: _ClassVar[int]
    JSON_FIELD_NUMBER: _ClassVar[int]
    KIND_FIELD_NUMBER: _ClassVar[int]
    STATUS_FIELD_NUMBER: _ClassVar[int]
    TIME_FIELD_NUMBER: _ClassVar[int]
    index: int
    json: str
    kind: str
    status: LifeStatus
    time: float
    def __init__(self, index: _Optional[int] = ..., time: _Optional[float] = ..., kind: _Optional[str] = ..., json: _Optional[str] = ..., status: _Optional[_Union[LifeStatus, _Mapping]] = ...) -> None: ...

class WatchLifeRequest(_message.Message):
    __slots__ = ["replay"]
    REPLAY_FIELD_NUMBER: _ClassVar[int]
    replay: bool
    def __init__(self, replay: bool = ...) -> None: ...
