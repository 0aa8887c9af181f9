from google.protobuf import empty_pb2 as _empty_pb2
from google.protobuf.internal import containers as _containers
from google.protobuf.internal import enum_type_wrapper as _enum_type_wrapper
from google.protobuf import descriptor as _descriptor
from google.protobuf import message as _message
from typing import ClassVar as _ClassVar, Iterable as _Iterable, Mapping as _Mapping, Optional as _Optional, Union as _Union

CAMERA_FIXED: CameraKind
CAMERA_FOLLOW: CameraKind
CAMERA_TOP: CameraKind
CONNECTOR_BOTTOM: ConnectorName
CONNECTOR_FRONT: ConnectorName
CONNECTOR_LEFT: ConnectorName
CONNECTOR_REAR: ConnectorName
CONNECTOR_RIGHT: ConnectorName
CONNECTOR_TOP: ConnectorName
DESCRIPTOR: _descriptor.FileDescriptor
MOTOR_LIMP: MotorDefect
MOTOR_OK: MotorDefect
MOTOR_STUCK: MotorDefect
SWITCH_OFF: Switch
SWITCH_ON: Switch
SWITCH_UNCHANGED: Switch

class AccelerometerSample(_message.Message):
    __slots__ = ["acceleration", "x", "y", "z"]
    ACCELERATION_FIELD_NUMBER: _ClassVar[int]
    X_FIELD_NUMBER: _ClassVar[int]
    Y_FIELD_NUMBER: _ClassVar[int]
    Z_FIELD_NUMBER: _ClassVar[int]
    acceleration: Vector3
    x: int
    y: int
    z: int
    def __init__(self, x: _Optional[int] = ..., y: _Optional[int] = ..., z: _Optional[int] = ..., acceleration: _Optional[_Union[Vector3, _Mapping]] = ...) -> None: ...

class AddCouplingRequest(_message.Message):
    __slots__ = ["from_id", "phase", "to_id", "weight"]
    FROM_ID_FIELD_NUMBER: _ClassVar[int]
    PHASE_FIELD_NUMBER: _ClassVar[int]
    TO_ID_FIELD_NUMBER: _ClassVar[int]
    WEIGHT_FIELD_NUMBER: _ClassVar[int]
    from_id: int
    phase: float
    to_id: int
    weight: float
    def __init__(self, from_id: _Optional[int] = ..., to_id: _Optional[int] = ..., phase: _Optional[float] = ..., weight: _Optional[float] = ...) -> None: ...

class Camera(_message.Message):
    __slots__ = ["azimuth", "distance", "elevation", "eye", "fov", "height", "kind", "target"]
    AZIMUTH_FIELD_NUMBER: _ClassVar[int]
    DISTANCE_FIELD_NUMBER: _ClassVar[int]
    ELEVATION_FIELD_NUMBER: _ClassVar[int]
    EYE_FIELD_NUMBER: _ClassVar[int]
    FOV_FIELD_NUMBER: _ClassVar[int]
    HEIGHT_FIELD_NUMBER: _ClassVar[int]
    KIND_FIELD_NUMBER: _ClassVar[int]
    TARGET_FIELD_NUMBER: _ClassVar[int]
    azimuth: float
    distance: float
    elevation: float
    eye: Vector3
    fov: float
    height: float
    kind: CameraKind
    target: Vector3
    def __init__(self, kind: _Optional[_Union[CameraKind, str]] = ..., distance: _Optional[float] = ..., elevation: _Optional[float] = ..., azimuth: _Optional[float] = ..., eye: _Optional[_Union[Vector3, _Mapping]] = ..., target: _Optional[_Union[Vector3, _Mapping]] = ..., height: _Optional[float] = ..., fov: _Optional[float] = ...) -> None: ...

class ConnectModulesRequest(_message.Message):
    __slots__ = ["angle_degrees", "from_connector", "from_id", "to_connector", "to_id"]
    ANGLE_DEGREES_FIELD_NUMBER: _ClassVar[int]
    FROM_CONNECTOR_FIELD_NUMBER: _ClassVar[int]
    FROM_ID_FIELD_NUMBER: _ClassVar[int]
    TO_CONNECTOR_FIELD_NUMBER: _ClassVar[int]
    TO_ID_FIELD_NUMBER: _ClassVar[int]
    angle_degrees: float
    from_connector: ConnectorName
    from_id: int
    to_connector: ConnectorName
    to_id: int
    def __init__(self, from_id: _Optional[int] = ..., from_connector: _Optional[_Union[ConnectorName, str]] = ..., to_id: _Optional[int] = ..., to_connector: _Optional[_Union[ConnectorName, str]] = ..., angle_degrees: _Optional[float] = ...) -> None: ...

class ConnectRobotRequest(_message.Message):
    __slots__ = ["link_timeout", "links_only"]
    LINKS_ONLY_FIELD_NUMBER: _ClassVar[int]
    LINK_TIMEOUT_FIELD_NUMBER: _ClassVar[int]
    link_timeout: float
    links_only: bool
    def __init__(self, link_timeout: _Optional[float] = ..., links_only: bool = ...) -> None: ...

class ConnectRobotResponse(_message.Message):
    __slots__ = ["elapsed", "frames_sent", "links"]
    ELAPSED_FIELD_NUMBER: _ClassVar[int]
    FRAMES_SENT_FIELD_NUMBER: _ClassVar[int]
    LINKS_FIELD_NUMBER: _ClassVar[int]
    elapsed: float
    frames_sent: int
    links: int
    def __init__(self, links: _Optional[int] = ..., elapsed: _Optional[float] = ..., frames_sent: _Optional[int] = ...) -> None: ...

class ControlMessageRequest(_message.Message):
    __slots__ = ["all", "cpg", "module_ids", "motors", "uart"]
    ALL_FIELD_NUMBER: _ClassVar[int]
    CPG_FIELD_NUMBER: _ClassVar[int]
    MODULE_IDS_FIELD_NUMBER: _ClassVar[int]
    MOTORS_FIELD_NUMBER: _ClassVar[int]
    UART_FIELD_NUMBER: _ClassVar[int]
    all: bool
    cpg: Switch
    module_ids: _containers.RepeatedScalarFieldContainer[int]
    motors: Switch
    uart: Switch
    def __init__(self, uart: _Optional[_Union[Switch, str]] = ..., cpg: _Optional[_Union[Switch, str]] = ..., motors: _Optional[_Union[Switch, str]] = ..., module_ids: _Optional[_Iterable[int]] = ..., all: bool = ...) -> None: ...

class CouplingRequest(_message.Message):
    __slots__ = ["from_id", "to_id"]
    FROM_ID_FIELD_NUMBER: _ClassVar[int]
    TO_ID_FIELD_NUMBER: _ClassVar[int]
    from_id: int
    to_id: int
    def __init__(self, from_id: _Optional[int] = ..., to_id: _Optional[int] = ...) -> None: ...

class ElapsedTimeResponse(_message.Message):
    __slots__ = ["seconds"]
    SECONDS_FIELD_NUMBER: _ClassVar[int]
    seconds: float
    def __init__(self, seconds: _Optional[float] = ...) -> None: ...

class EvaluateRequest(_message.Message):
    __slots__ = ["config_xml", "duration", "frames", "ground", "module_defects", "morphology_xml", "motor_defects", "parameters", "seed", "time_step", "trajectory_period", "upside_down", "warmup", "world"]
    CONFIG_XML_FIELD_NUMBER: _ClassVar[int]
    DURATION_FIELD_NUMBER: _ClassVar[int]
    FRAMES_FIELD_NUMBER: _ClassVar[int]
    GROUND_FIELD_NUMBER: _ClassVar[int]
    MODULE_DEFECTS_FIELD_NUMBER: _ClassVar[int]
    MORPHOLOGY_XML_FIELD_NUMBER: _ClassVar[int]
    MOTOR_DEFECTS_FIELD_NUMBER: _ClassVar[int]
    PARAMETERS_FIELD_NUMBER: _ClassVar[int]
    SEED_FIELD_NUMBER: _ClassVar[int]
    TIME_STEP_FIELD_NUMBER: _ClassVar[int]
    TRAJECTORY_PERIOD_FIELD_NUMBER: _ClassVar[int]
    UPSIDE_DOWN_FIELD_NUMBER: _ClassVar[int]
    WARMUP_FIELD_NUMBER: _ClassVar[int]
    WORLD_FIELD_NUMBER: _ClassVar[int]
    config_xml: str
    duration: float
    frames: EvaluationFrames
    ground: SetGroundRequest
    module_defects: _containers.RepeatedCompositeFieldContainer[SetModuleDefectRequest]
    morphology_xml: str
    motor_defects: _containers.RepeatedCompositeFieldContainer[SetMotorDefectRequest]
    parameters: _containers.RepeatedCompositeFieldContainer[ParameterValue]
    seed: int
    time_step: float
    trajectory_period: float
    upside_down: bool
    warmup: float
    world: str
    def __init__(self, config_xml: _Optional[str] = ..., world: _Optional[str] = ..., morphology_xml: _Optional[str] = ..., parameters: _Optional[_Iterable[_Union[ParameterValue, _Mapping]]] = ..., warmup: _Optional[float] = ..., duration: _Optional[float] = ..., seed: _Optional[int] = ..., trajectory_period: _Optional[float] = ..., time_step: _Optional[float] = ..., motor_defects: _Optional[_Iterable[_Union[SetMotorDefectRequest, _Mapping]]] = ..., module_defects: _Optional[_Iterable[_Union[SetModuleDefectRequest, _Mapping]]] = ..., ground: _Optional[_Union[SetGroundRequest, _Mapping]] = ..., upside_down: bool = ..., frames: _Optional[_Union[EvaluationFrames, _Mapping]] = ...) -> None: ...

class EvaluateResponse(_message.Message):
    __slots__ = ["distance", "diverged", "divergence", "final_pose", "frames", "mp4", "mp4_frames", "trajectory", "velocity", "video_note", "wall_seconds"]
    DISTANCE_FIELD_NUMBER: _ClassVar[int]
    DIVERGED_FIELD_NUMBER: _ClassVar[int]
    DIVERGENCE_FIELD_NUMBER: _ClassVar[int]
    FINAL_POSE_FIELD_NUMBER: _ClassVar[int]
    FRAMES_FIELD_NUMBER: _ClassVar[int]
    MP4_FIELD_NUMBER: _ClassVar[int]
    MP4_FRAMES_FIELD_NUMBER: _ClassVar[int]
    TRAJECTORY_FIELD_NUMBER: _ClassVar[int]
    VELOCITY_FIELD_NUMBER: _ClassVar[int]
    VIDEO_NOTE_FIELD_NUMBER: _ClassVar[int]
    WALL_SECONDS_FIELD_NUMBER: _ClassVar[int]
    distance: float
    diverged: bool
    divergence: str
    final_pose: Pose
    frames: _containers.RepeatedCompositeFieldContainer[VideoFrame]
    mp4: bytes
    mp4_frames: int
    trajectory: _containers.RepeatedCompositeFieldContainer[TrajectorySample]
    velocity: float
    video_note: str
    wall_seconds: float
    def __init__(self, velocity: _Optional[float] = ..., distance: _Optional[float] = ..., final_pose: _Optional[_Union[Pose, _Mapping]] = ..., trajectory: _Optional[_Iterable[_Union[TrajectorySample, _Mapping]]] = ..., diverged: bool = ..., divergence: _Optional[str] = ..., wall_seconds: _Optional[float] = ..., frames: _Optional[_Iterable[_Union[VideoFrame, _Mapping]]] = ..., mp4: _Optional[bytes] = ..., mp4_frames: _Optional[int] = ..., video_note: _Optional[str] = ...) -> None: ...

class EvaluationFrames(_message.Message):
    __slots__ = ["camera", "frame_rate", "height", "hide_labels", "hide_legend", "mp4", "png_frames", "width"]
    CAMERA_FIELD_NUMBER: _ClassVar[int]
    FRAME_RATE_FIELD_NUMBER: _ClassVar[int]
    HEIGHT_FIELD_NUMBER: _ClassVar[int]
    HIDE_LABELS_FIELD_NUMBER: _ClassVar[int]
    HIDE_LEGEND_FIELD_NUMBER: _ClassVar[int]
    MP4_FIELD_NUMBER: _ClassVar[int]
    PNG_FRAMES_FIELD_NUMBER: _ClassVar[int]
    WIDTH_FIELD_NUMBER: _ClassVar[int]
    camera: Camera
    frame_rate: float
    height: int
    hide_labels: bool
    hide_legend: bool
    mp4: bool
    png_frames: _containers.RepeatedScalarFieldContainer[int]
    width: int
    def __init__(self, camera: _Optional[_Union[Camera, _Mapping]] = ..., width: _Optional[int] = ..., height: _Optional[int] = ..., hide_labels: bool = ..., hide_legend: bool = ..., frame_rate: _Optional[float] = ..., mp4: bool = ..., png_frames: _Optional[_Iterable[int]] = ...) -> None: ...

class FlushResponse(_message.Message):
    __slots__ = ["frames_sent"]
    FRAMES_SENT_FIELD_NUMBER: _ClassVar[int]
    frames_sent: int
    def __init__(self, frames_sent: _Optional[int] = ...) -> None: ...

class GetAccelerometerRequest(_message.Message):
    __slots__ = ["module_id", "samples"]
    MODULE_ID_FIELD_NUMBER: _ClassVar[int]
    SAMPLES_FIELD_NUMBER: _ClassVar[int]
    module_id: int
    samples: int
    def __init__(self, module_id: _Optional[int] = ..., samples: _Optional[int] = ...) -> None: ...

class GetAccelerometerResponse(_message.Message):
    __slots__ = ["samples"]
    SAMPLES_FIELD_NUMBER: _ClassVar[int]
    samples: _containers.RepeatedCompositeFieldContainer[AccelerometerSample]
    def __init__(self, samples: _Optional[_Iterable[_Union[AccelerometerSample, _Mapping]]] = ...) -> None: ...

class GetAllModulesIdResponse(_message.Message):
    __slots__ = ["module_ids"]
    MODULE_IDS_FIELD_NUMBER: _ClassVar[int]
    module_ids: _containers.RepeatedScalarFieldContainer[int]
    def __init__(self, module_ids: _Optional[_Iterable[int]] = ...) -> None: ...

class GetInfoResponse(_message.Message):
    __slots__ = ["backend", "builtin_worlds", "connected", "free_run_factor", "master_node", "max_concurrent_calls", "version", "worker_capacity", "world"]
    BACKEND_FIELD_NUMBER: _ClassVar[int]
    BUILTIN_WORLDS_FIELD_NUMBER: _ClassVar[int]
    CONNECTED_FIELD_NUMBER: _ClassVar[int]
    FREE_RUN_FACTOR_FIELD_NUMBER: _ClassVar[int]
    MASTER_NODE_FIELD_NUMBER: _ClassVar[int]
    MAX_CONCURRENT_CALLS_FIELD_NUMBER: _ClassVar[int]
    VERSION_FIELD_NUMBER: _ClassVar[int]
    WORKER_CAPACITY_FIELD_NUMBER: _ClassVar[int]
    WORLD_FIELD_NUMBER: _ClassVar[int]
    backend: str
    builtin_worlds: _containers.RepeatedScalarFieldContainer[str]
    connected: bool
    free_run_factor: float
    master_node: int
    max_concurrent_calls: int
    version: str
    worker_capacity: int
    world: str
    def __init__(self, version: _Optional[str] = ..., backend: _Optional[str] = ..., worker_capacity: _Optional[int] = ..., world: _Optional[str] = ..., master_node: _Optional[int] = ..., connected: bool = ..., free_run_factor: _Optional[float] = ..., max_concurrent_calls: _Optional[int] = ..., builtin_worlds: _Optional[_Iterable[str]] = ...) -> None: ...

class GetMorphologyResponse(_message.Message):
    __slots__ = ["central_module", "morphology_xml"]
    CENTRAL_MODULE_FIELD_NUMBER: _ClassVar[int]
    MORPHOLOGY_XML_FIELD_NUMBER: _ClassVar[int]
    central_module: int
    morphology_xml: str
    def __init__(self, morphology_xml: _Optional[str] = ..., central_module: _Optional[int] = ...) -> None: ...

class GetOrientationRequest(_message.Message):
    __slots__ = ["module_id", "reference_up", "samples"]
    MODULE_ID_FIELD_NUMBER: _ClassVar[int]
    REFERENCE_UP_FIELD_NUMBER: _ClassVar[int]
    SAMPLES_FIELD_NUMBER: _ClassVar[int]
    module_id: int
    reference_up: Vector3
    samples: int
    def __init__(self, module_id: _Optional[int] = ..., samples: _Optional[int] = ..., reference_up: _Optional[_Union[Vector3, _Mapping]] = ...) -> None: ...

class GetOrientationResponse(_message.Message):
    __slots__ = ["magnitude", "max_deviation", "samples", "tilt", "up", "upside_down", "valid"]
    MAGNITUDE_FIELD_NUMBER: _ClassVar[int]
    MAX_DEVIATION_FIELD_NUMBER: _ClassVar[int]
    SAMPLES_FIELD_NUMBER: _ClassVar[int]
    TILT_FIELD_NUMBER: _ClassVar[int]
    UPSIDE_DOWN_FIELD_NUMBER: _ClassVar[int]
    UP_FIELD_NUMBER: _ClassVar[int]
    VALID_FIELD_NUMBER: _ClassVar[int]
    magnitude: float
    max_deviation: float
    samples: int
    tilt: float
    up: Vector3
    upside_down: bool
    valid: bool
    def __init__(self, valid: bool = ..., up: _Optional[_Union[Vector3, _Mapping]] = ..., tilt: _Optional[float] = ..., upside_down: bool = ..., magnitude: _Optional[float] = ..., max_deviation: _Optional[float] = ..., samples: _Optional[int] = ...) -> None: ...

class GetServoAnglesRequest(_message.Message):
    __slots__ = ["module_ids"]
    MODULE_IDS_FIELD_NUMBER: _ClassVar[int]
    module_ids: _containers.RepeatedScalarFieldContainer[int]
    def __init__(self, module_ids: _Optional[_Iterable[int]] = ...) -> None: ...

class GetServoAnglesResponse(_message.Message):
    __slots__ = ["angles"]
    ANGLES_FIELD_NUMBER: _ClassVar[int]
    angles: _containers.RepeatedCompositeFieldContainer[ServoAngle]
    def __init__(self, angles: _Optional[_Iterable[_Union[ServoAngle, _Mapping]]] = ...) -> None: ...

class LoadConfigRequest(_message.Message):
    __slots__ = ["config_xml", "source_name"]
    CONFIG_XML_FIELD_NUMBER: _ClassVar[int]
    SOURCE_NAME_FIELD_NUMBER: _ClassVar[int]
    config_xml: str
    source_name: str
    def __init__(self, config_xml: _Optional[str] = ..., source_name: _Optional[str] = ...) -> None: ...

class ModuleRequest(_message.Message):
    __slots__ = ["module_id"]
    MODULE_ID_FIELD_NUMBER: _ClassVar[int]
    module_id: int
    def __init__(self, module_id: _Optional[int] = ...) -> None: ...

class OpenSimulationRequest(_message.Message):
    __slots__ = ["config_xml", "morphology_xml", "seed", "time_step", "world"]
    CONFIG_XML_FIELD_NUMBER: _ClassVar[int]
    MORPHOLOGY_XML_FIELD_NUMBER: _ClassVar[int]
    SEED_FIELD_NUMBER: _ClassVar[int]
    TIME_STEP_FIELD_NUMBER: _ClassVar[int]
    WORLD_FIELD_NUMBER: _ClassVar[int]
    config_xml: str
    morphology_xml: str
    seed: int
    time_step: float
    world: str
    def __init__(self, world: _Optional[str] = ..., morphology_xml: _Optional[str] = ..., config_xml: _Optional[str] = ..., seed: _Optional[int] = ..., time_step: _Optional[float] = ...) -> None: ...

class OpenSimulationResponse(_message.Message):
    __slots__ = ["central_module", "module_ids"]
    CENTRAL_MODULE_FIELD_NUMBER: _ClassVar[int]
    MODULE_IDS_FIELD_NUMBER: _ClassVar[int]
    central_module: int
    module_ids: _containers.RepeatedScalarFieldContainer[int]
    def __init__(self, module_ids: _Optional[_Iterable[int]] = ..., central_module: _Optional[int] = ...) -> None: ...

class ParameterValue(_message.Message):
    __slots__ = ["name", "value"]
    NAME_FIELD_NUMBER: _ClassVar[int]
    VALUE_FIELD_NUMBER: _ClassVar[int]
    name: str
    value: float
    def __init__(self, name: _Optional[str] = ..., value: _Optional[float] = ...) -> None: ...

class Pose(_message.Message):
    __slots__ = ["orientation", "position"]
    ORIENTATION_FIELD_NUMBER: _ClassVar[int]
    POSITION_FIELD_NUMBER: _ClassVar[int]
    orientation: Quaternion
    position: Vector3
    def __init__(self, position: _Optional[_Union[Vector3, _Mapping]] = ..., orientation: _Optional[_Union[Quaternion, _Mapping]] = ...) -> None: ...

class Quaternion(_message.Message):
    __slots__ = ["w", "x", "y", "z"]
    W_FIELD_NUMBER: _ClassVar[int]
    X_FIELD_NUMBER: _ClassVar[int]
    Y_FIELD_NUMBER: _ClassVar[int]
    Z_FIELD_NUMBER: _ClassVar[int]
    w: float
    x: float
    y: float
    z: float
    def __init__(self, w: _Optional[float] = ..., x: _Optional[float] = ..., y: _Optional[float] = ..., z: _Optional[float] = ...) -> None: ...

class RecordFramesRequest(_message.Message):
    __slots__ = ["camera", "frame_rate", "height", "hide_labels", "hide_legend", "seconds", "watch", "width"]
    CAMERA_FIELD_NUMBER: _ClassVar[int]
    FRAME_RATE_FIELD_NUMBER: _ClassVar[int]
    HEIGHT_FIELD_NUMBER: _ClassVar[int]
    HIDE_LABELS_FIELD_NUMBER: _ClassVar[int]
    HIDE_LEGEND_FIELD_NUMBER: _ClassVar[int]
    SECONDS_FIELD_NUMBER: _ClassVar[int]
    WATCH_FIELD_NUMBER: _ClassVar[int]
    WIDTH_FIELD_NUMBER: _ClassVar[int]
    camera: Camera
    frame_rate: float
    height: int
    hide_labels: bool
    hide_legend: bool
    seconds: float
    watch: bool
    width: int
    def __init__(self, camera: _Optional[_Union[Camera, _Mapping]] = ..., width: _Optional[int] = ..., height: _Optional[int] = ..., hide_labels: bool = ..., hide_legend: bool = ..., frame_rate: _Optional[float] = ..., seconds: _Optional[float] = ..., watch: bool = ...) -> None: ...

class RenderFrameRequest(_message.Message):
    __slots__ = ["camera", "height", "hide_labels", "hide_legend", "width"]
    CAMERA_FIELD_NUMBER: _ClassVar[int]
    HEIGHT_FIELD_NUMBER: _ClassVar[int]
    HIDE_LABELS_FIELD_NUMBER: _ClassVar[int]
    HIDE_LEGEND_FIELD_NUMBER: _ClassVar[int]
    WIDTH_FIELD_NUMBER: _ClassVar[int]
    camera: Camera
    height: int
    hide_labels: bool
    hide_legend: bool
    width: int
    def __init__(self, camera: _Optional[_Union[Camera, _Mapping]] = ..., width: _Optional[int] = ..., height: _Optional[int] = ..., hide_labels: bool = ..., hide_legend: bool = ...) -> None: ...

class RenderFrameResponse(_message.Message):
    __slots__ = ["png", "time"]
    PNG_FIELD_NUMBER: _ClassVar[int]
    TIME_FIELD_NUMBER: _ClassVar[int]
    png: bytes
    time: float
    def __init__(self, png: _Optional[bytes] = ..., time: _Optional[float] = ...) -> None: ...

class RobotPositionResponse(_message.Message):
    __slots__ = ["orientation", "position", "source", "time"]
    ORIENTATION_FIELD_NUMBER: _ClassVar[int]
    POSITION_FIELD_NUMBER: _ClassVar[int]
    SOURCE_FIELD_NUMBER: _ClassVar[int]
    TIME_FIELD_NUMBER: _ClassVar[int]
    orientation: Quaternion
    position: Vector3
    source: str
    time: float
    def __init__(self, position: _Optional[_Union[Vector3, _Mapping]] = ..., orientation: _Optional[_Union[Quaternion, _Mapping]] = ..., time: _Optional[float] = ..., source: _Optional[str] = ...) -> None: ...

class RunTransformationScriptRequest(_message.Message):
    __slots__ = ["script_xml"]
    SCRIPT_XML_FIELD_NUMBER: _ClassVar[int]
    script_xml: str
    def __init__(self, script_xml: _Optional[str] = ...) -> None: ...

class SaveConfigResponse(_message.Message):
    __slots__ = ["config_xml"]
    CONFIG_XML_FIELD_NUMBER: _ClassVar[int]
    config_xml: str
    def __init__(self, config_xml: _Optional[str] = ...) -> None: ...

class ServoAngle(_message.Message):
    __slots__ = ["angle", "module_id"]
    ANGLE_FIELD_NUMBER: _ClassVar[int]
    MODULE_ID_FIELD_NUMBER: _ClassVar[int]
    angle: float
    module_id: int
    def __init__(self, module_id: _Optional[int] = ..., angle: _Optional[float] = ...) -> None: ...

class SetCouplingValueRequest(_message.Message):
    __slots__ = ["from_id", "to_id", "value"]
    FROM_ID_FIELD_NUMBER: _ClassVar[int]
    TO_ID_FIELD_NUMBER: _ClassVar[int]
    VALUE_FIELD_NUMBER: _ClassVar[int]
    from_id: int
    to_id: int
    value: float
    def __init__(self, from_id: _Optional[int] = ..., to_id: _Optional[int] = ..., value: _Optional[float] = ...) -> None: ...

class SetFreeRunRequest(_message.Message):
    __slots__ = ["real_time_factor"]
    REAL_TIME_FACTOR_FIELD_NUMBER: _ClassVar[int]
    real_time_factor: float
    def __init__(self, real_time_factor: _Optional[float] = ...) -> None: ...

class SetGroundRequest(_message.Message):
    __slots__ = ["friction", "slope", "slope_direction"]
    FRICTION_FIELD_NUMBER: _ClassVar[int]
    SLOPE_DIRECTION_FIELD_NUMBER: _ClassVar[int]
    SLOPE_FIELD_NUMBER: _ClassVar[int]
    friction: float
    slope: float
    slope_direction: float
    def __init__(self, friction: _Optional[float] = ..., slope: _Optional[float] = ..., slope_direction: _Optional[float] = ...) -> None: ...

class SetModuleDefectRequest(_message.Message):
    __slots__ = ["defective", "module_id"]
    DEFECTIVE_FIELD_NUMBER: _ClassVar[int]
    MODULE_ID_FIELD_NUMBER: _ClassVar[int]
    defective: bool
    module_id: int
    def __init__(self, module_id: _Optional[int] = ..., defective: bool = ...) -> None: ...

class SetModuleValueRequest(_message.Message):
    __slots__ = ["module_id", "value"]
    MODULE_ID_FIELD_NUMBER: _ClassVar[int]
    VALUE_FIELD_NUMBER: _ClassVar[int]
    module_id: int
    value: float
    def __init__(self, module_id: _Optional[int] = ..., value: _Optional[float] = ...) -> None: ...

class SetMotorDefectRequest(_message.Message):
    __slots__ = ["defect", "module_id"]
    DEFECT_FIELD_NUMBER: _ClassVar[int]
    MODULE_ID_FIELD_NUMBER: _ClassVar[int]
    defect: MotorDefect
    module_id: int
    def __init__(self, module_id: _Optional[int] = ..., defect: _Optional[_Union[MotorDefect, str]] = ...) -> None: ...

class SimulationModeEnabledResponse(_message.Message):
    __slots__ = ["enabled"]
    ENABLED_FIELD_NUMBER: _ClassVar[int]
    enabled: bool
    def __init__(self, enabled: bool = ...) -> None: ...

class SleepRequest(_message.Message):
    __slots__ = ["real_time", "seconds"]
    REAL_TIME_FIELD_NUMBER: _ClassVar[int]
    SECONDS_FIELD_NUMBER: _ClassVar[int]
    real_time: bool
    seconds: float
    def __init__(self, seconds: _Optional[float] = ..., real_time: bool = ...) -> None: ...

class SleepResponse(_message.Message):
    __slots__ = ["time"]
    TIME_FIELD_NUMBER: _ClassVar[int]
    time: float
    def __init__(self, time: _Optional[float] = ...) -> None: ...

class StateEvent(_message.Message):
    __slots__ = ["detail", "kind", "module_id"]
    DETAIL_FIELD_NUMBER: _ClassVar[int]
    KIND_FIELD_NUMBER: _ClassVar[int]
    MODULE_ID_FIELD_NUMBER: _ClassVar[int]
    detail: str
    kind: str
    module_id: int
    def __init__(self, kind: _Optional[str] = ..., module_id: _Optional[int] = ..., detail: _Optional[str] = ...) -> None: ...

class StateUpdate(_message.Message):
    __slots__ = ["central", "events", "time", "velocity"]
    CENTRAL_FIELD_NUMBER: _ClassVar[int]
    EVENTS_FIELD_NUMBER: _ClassVar[int]
    TIME_FIELD_NUMBER: _ClassVar[int]
    VELOCITY_FIELD_NUMBER: _ClassVar[int]
    central: Pose
    events: _containers.RepeatedCompositeFieldContainer[StateEvent]
    time: float
    velocity: Vector3
    def __init__(self, time: _Optional[float] = ..., central: _Optional[_Union[Pose, _Mapping]] = ..., velocity: _Optional[_Union[Vector3, _Mapping]] = ..., events: _Optional[_Iterable[_Union[StateEvent, _Mapping]]] = ...) -> None: ...

class TrajectorySample(_message.Message):
    __slots__ = ["position", "time"]
    POSITION_FIELD_NUMBER: _ClassVar[int]
    TIME_FIELD_NUMBER: _ClassVar[int]
    position: Vector3
    time: float
    def __init__(self, time: _Optional[float] = ..., position: _Optional[_Union[Vector3, _Mapping]] = ...) -> None: ...

class ValueResponse(_message.Message):
    __slots__ = ["value"]
    VALUE_FIELD_NUMBER: _ClassVar[int]
    value: float
    def __init__(self, value: _Optional[float] = ...) -> None: ...

class Vector3(_message.Message):
    __slots__ = ["x", "y", "z"]
    X_FIELD_NUMBER: _ClassVar[int]
    Y_FIELD_NUMBER: _ClassVar[int]
    Z_FIELD_NUMBER: _ClassVar[int]
    x: float
    y: float
    z: float
    def __init__(self, x: _Optional[float] = ..., y: _Optional[float] = ..., z: _Optional[float] = ...) -> None: ...

class VideoFrame(_message.Message):
    __slots__ = ["index", "png", "time"]
    INDEX_FIELD_NUMBER: _ClassVar[int]
    PNG_FIELD_NUMBER: _ClassVar[int]
    TIME_FIELD_NUMBER: _ClassVar[int]
    index: int
    png: bytes
    time: float
    def __init__(self, index: _Optional[int] = ..., time: _Optional[float] = ..., png: _Optional[bytes] = ...) -> None: ...

class WatchStateRequest(_message.Message):
    __slots__ = ["period"]
    PERIOD_FIELD_NUMBER: _ClassVar[int]
    period: float
    def __init__(self, period: _Optional[float] = ...) -> None: ...

class Switch(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
    __slots__ = []

class ConnectorName(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
    __slots__ = []

class MotorDefect(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
    __slots__ = []

class CameraKind(int, metaclass=_enum_type_wrapper.EnumTypeWrapper):
    __slots__ = []
