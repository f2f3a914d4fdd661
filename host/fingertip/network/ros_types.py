"""ROS 2 type names, type hashes and DDS type descriptions, derived from the recorder's
message definitions (:data:`fingertip.record.schemas.SCHEMAS`): nothing is written twice.

- :func:`dds_type_name`: ``geometry_msgs/msg/WrenchStamped`` ->
  ``geometry_msgs::msg::dds_::WrenchStamped_`` (how every ROS 2 rmw names DDS types);
- :func:`type_hash`: the RIHS01 hash that Iron and later put in an endpoint's USER_DATA
  (computed by ``rosbags`` from the same definitions);
- :func:`idl_struct`: a cyclonedds ``IdlStruct`` with the same members, so the DDS topic
  carries the right XTypes type information. Payloads are never serialised by it: they are
  the recorder's CDR bytes (the tests check that both agree).
"""
from __future__ import annotations

import functools
from typing import Any

from ..record import schemas as S
from . import require
from .diagnostics import DEFINITIONS as DIAGNOSTIC_DEFS

TRIGGER = "std_srvs/srv/Trigger"
TRIGGER_REQUEST = "std_srvs/srv/Trigger_Request"
TRIGGER_RESPONSE = "std_srvs/srv/Trigger_Response"

# std_srvs/srv/Trigger, as rosidl splits it. An empty request gets the placeholder member
# that rosidl adds to every empty structure (IDL has no empty structs).
SERVICE_DEFS: dict[str, str] = {
    TRIGGER_REQUEST: "uint8 structure_needs_at_least_one_member",
    TRIGGER_RESPONSE: "bool success # indicate successful run of triggered service\n"
                      "string message # informational, e.g. for error messages",
}

# A service's own RIHS01 hash (what rmw_zenoh keys services by) describes the service as a
# structure of its request, response and event messages (REP 2011, as
# rosidl_generator_type_description builds it). The event message carries
# service_msgs/ServiceEventInfo, whose ``char[16]`` rosidl turns into ``uint8[16]`` in IDL
# before hashing (rosbags' own copy keeps ``char``, which hashes differently).
SERVICE_EVENT_INFO = "service_msgs/msg/ServiceEventInfo"
SERVICE_EVENT_INFO_DEF = ("uint8 event_type\nbuiltin_interfaces/Time stamp\n"
                          "uint8[16] client_gid\nint64 sequence_number")
SERVICES = {TRIGGER: (TRIGGER_REQUEST, TRIGGER_RESPONSE)}

CLOCK = "rosgraph_msgs/msg/Clock"
GID = "rmw_dds_common/msg/Gid"
NODE_ENTITIES = "rmw_dds_common/msg/NodeEntitiesInfo"
PARTICIPANT_ENTITIES = "rmw_dds_common/msg/ParticipantEntitiesInfo"
OTHER_DEFS: dict[str, str] = {
    # /clock, for subscribers with use_sim_time while a recording is replayed.
    CLOCK: "builtin_interfaces/Time clock",
    # ros_discovery_info, which tells ROS 2 tools which node owns which readers and writers
    # (rmw_dds_common as of Jazzy and Kilted: 16-byte GIDs; Humble's are 24 bytes).
    GID: "char[16] data",
    NODE_ENTITIES: "string<=256 node_namespace\nstring<=256 node_name\n"
                   "rmw_dds_common/Gid[] reader_gid_seq\nrmw_dds_common/Gid[] writer_gid_seq",
    PARTICIPANT_ENTITIES: "rmw_dds_common/Gid gid\n"
                          "rmw_dds_common/NodeEntitiesInfo[] node_entities_info_seq",
}

_PRIMITIVES = ("bool", "byte", "char", "int8", "uint8", "int16", "uint16", "int32", "uint32",
               "int64", "uint64", "float32", "float64", "string")


def full_name(ref: str) -> str:
    """``std_msgs/Header`` -> ``std_msgs/msg/Header`` (names in .msg files omit ``msg``)."""
    parts = ref.split("/")
    if len(parts) == 2:
        return f"{parts[0]}/msg/{parts[1]}"
    return ref


def dds_type_name(name: str) -> str:
    """``pkg/msg/Type`` -> ``pkg::msg::dds_::Type_`` (``srv`` types likewise)."""
    pkg, kind, typ = full_name(name).split("/")
    return f"{pkg}::{kind}::dds_::{typ}_"


def _fields(text: str) -> list[tuple[str, str]]:
    """``(type, name)`` of each field of one .msg definition (comments and constants out)."""
    out = []
    for line in text.splitlines():
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        ftype, fname = line.split()[:2]
        if "=" in fname:  # a constant (NAME=value), not a field
            continue
        out.append((ftype, fname))
    return out


@functools.cache
def definitions() -> dict[str, str]:
    """Every type we publish or use -> its own .msg text (dependencies split apart)."""
    defs: dict[str, str] = {}
    for top, text in S.SCHEMAS.items():
        sections = text.split(S.SEP + "\n")
        defs[top] = sections[0].rstrip("\n")
        for sec in sections[1:]:
            head, _, body = sec.partition("\n")
            if not head.startswith("MSG: "):
                raise ValueError(f"bad section in schema {top}: {head!r}")
            defs[full_name(head[5:].strip())] = body.rstrip("\n")
    defs.update(SERVICE_DEFS)
    defs.update(OTHER_DEFS)
    defs.update(DIAGNOSTIC_DEFS)
    return defs


def fields(name: str) -> list[tuple[str, str]]:
    """Fields of type ``name`` as ``(full type or primitive[], field name)``."""
    out = []
    for ftype, fname in _fields(definitions()[full_name(name)]):
        base, bracket, size = ftype.partition("[")
        if "/" in base:
            base = full_name(base)
        elif base.split("<=")[0] not in _PRIMITIVES:
            raise ValueError(f"{name}.{fname}: unsupported field type {ftype!r}")
        out.append((base + bracket + size, fname))
    return out


@functools.cache
def _typestore():
    typesys = require("rosbags.typesys", "computing ROS 2 type hashes")
    store = typesys.get_typestore(typesys.Stores.EMPTY)
    types: dict[str, Any] = {}
    for name, text in definitions().items():
        if name == "builtin_interfaces/msg/Time" or "/srv/" in name:
            continue  # rosbags knows Time; service parts are hashed as a service by rmw
        types.update(typesys.get_types_from_msg(text, name))
    store.register(types)
    return store


@functools.cache
def type_hash(name: str) -> str:
    """``RIHS01_<64 hex digits>`` of message type ``name``, or of service type ``name``
    (one of :data:`SERVICES`, e.g. ``std_srvs/srv/Trigger``) and its parts."""
    name = full_name(name)
    for service, parts in SERVICES.items():
        if name == service or name in parts or name == service + "_Event":
            return _service_typestore(service).hash_rihs01(name)
    return _typestore().hash_rihs01(full_name(name))


@functools.cache
def _service_typestore(service: str):
    """A typestore holding ``service`` as REP 2011 describes a service: fields
    ``request_message``, ``response_message`` and ``event_message`` (``<srv>_Event``:
    ``info``, then the request and the response as sequences of at most one)."""
    typesys = require("rosbags.typesys", "computing ROS 2 type hashes")
    request, response = SERVICES[service]
    event = service + "_Event"
    texts = {SERVICE_EVENT_INFO: SERVICE_EVENT_INFO_DEF,
             request: definitions()[request], response: definitions()[response],
             event: (f"{SERVICE_EVENT_INFO} info\n{request}[<=1] request\n"
                     f"{response}[<=1] response"),
             service: (f"{request} request_message\n{response} response_message\n"
                       f"{event} event_message")}

    def srv_names(x: Any) -> Any:  # rosbags files every type under msg/: put srv/ back
        if isinstance(x, str):
            return x.replace("/srv/msg/", "/srv/")
        if isinstance(x, (tuple, list)):
            return type(x)(srv_names(v) for v in x)
        return x
    types: dict[str, Any] = {}
    for name, text in texts.items():
        for n, d in typesys.get_types_from_msg(text, name).items():
            types[srv_names(n)] = srv_names(d)
    store = typesys.get_typestore(typesys.Stores.EMPTY)
    store.register(types)
    return store


def user_data(name: str) -> bytes:
    """USER_DATA of a reader or writer of ``name``, as rmw implementations since Iron write
    it (``typehash=RIHS01_...;``)."""
    return f"typehash={type_hash(name)};".encode()


@functools.cache
def idl_struct(name: str) -> type:
    """A cyclonedds ``IdlStruct`` class mirroring ROS 2 type ``name``."""
    idl = require("cyclonedds.idl", "ROS 2 over DDS")
    from cyclonedds.idl import types as T

    prim = {"bool": bool, "byte": T.uint8, "char": T.uint8, "int8": T.int8, "uint8": T.uint8,
            "int16": T.int16, "uint16": T.uint16, "int32": T.int32, "uint32": T.uint32,
            "int64": T.int64, "uint64": T.uint64, "float32": T.float32,
            "float64": T.float64, "string": str}
    members: dict[str, Any] = {}
    if "/srv/" in full_name(name):
        # Service samples carry rmw_cyclonedds' request id ahead of the members
        # (cdds_request_header_t); Cyclone checks payloads against the type, so it is part
        # of the DDS type here.
        members.update(guid=T.uint64, seq=T.int64)
    for ftype, fname in fields(name):
        base, _, size = ftype.partition("[")
        if base.startswith("string<="):  # bounded string
            t = T.bounded_str[int(base[len("string<="):])]
        else:
            t = prim[base] if base in prim else idl_struct(base)
        if size == "]":
            t = T.sequence[t]
        elif size:  # fixed array T[N]
            t = T.array[t, int(size[:-1])]
        members[fname] = t
    cls_name = full_name(name).split("/")[-1] + "_"
    return idl.make_idl_struct(cls_name, dds_type_name(name), members)
