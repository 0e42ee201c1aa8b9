"""Cross-check cowork_msgs against rosbags (pure-Python ROS 2 type system and CDR codec).

Usage: check_msgs.py CODEC [SEED]   (CODEC: path of the msg_codec example binary)

1. Parses every .msg text of cowork_msgs (custom and the standard copies) with rosbags'
   get_types_from_msg, into an otherwise empty type store.
2. The standard types must have the same fields (names, types, order) and constants as
   rosbags' own ROS 2 Jazzy store.
3. Every full ros2msg definition (with MSG: sections) must parse, and give for every type in it
   the same fields as the .msg texts alone; constants must equal the Rust constants.
4. For every type, random sample messages are serialised to CDR by rosbags and by the Rust code
   (from the same JSON values); the bytes must be identical, and each side must decode the
   other's bytes to the same values.
"""

from __future__ import annotations

import json
import random
import subprocess
import sys
from typing import Any

import numpy as np
from rosbags.interfaces import Nodetype
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

NUMPY_TYPES = {
    'bool': np.bool_, 'byte': np.uint8, 'char': np.uint8, 'int8': np.int8, 'uint8': np.uint8,
    'int16': np.int16, 'uint16': np.uint16, 'int32': np.int32, 'uint32': np.uint32,
    'int64': np.int64, 'uint64': np.uint64, 'float32': np.float32, 'float64': np.float64,
}
INT_RANGES = {
    'byte': (0, 255), 'char': (0, 255), 'int8': (-128, 127), 'uint8': (0, 255),
    'int16': (-2**15, 2**15 - 1), 'uint16': (0, 2**16 - 1),
    'int32': (-2**31, 2**31 - 1), 'uint32': (0, 2**32 - 1),
    'int64': (-2**63, 2**63 - 1), 'uint64': (0, 2**64 - 1),
}
ALPHABET = 'abcXYZ_019 /.()äß€'


def run_codec(codec: str, mode: str, payload: Any = None) -> Any:
    out = subprocess.run(
        [codec, mode], input=json.dumps(payload) if payload is not None else '',
        capture_output=True, text=True, check=False,
    )
    if out.returncode != 0:
        sys.exit(f'msg_codec {mode} failed:\n{out.stderr}')
    return json.loads(out.stdout)


def rand_base(rng: random.Random, name: str) -> Any:
    if name == 'bool':
        return rng.random() < 0.5
    if name in INT_RANGES:
        lo, hi = INT_RANGES[name]
        return rng.choice([lo, hi, 0, rng.randint(lo, hi)])
    if name == 'float32':
        # Dyadic values are exact in f32 and print identically everywhere.
        return rng.randint(-2**16, 2**16) / 16
    if name == 'float64':
        return rng.choice([0.0, -0.0, rng.randint(-2**40, 2**40) / 64, rng.randint(-9, 9) * 2.0**-30])
    if name == 'string':
        return ''.join(rng.choice(ALPHABET) for _ in range(rng.randint(0, 9)))
    raise ValueError(f'unsupported base type {name}')


def rand_value(store, rng: random.Random, desc) -> Any:
    """A random value for a field description, in rosbags' Python representation."""
    kind, detail = desc
    if kind == Nodetype.BASE:
        return rand_base(rng, detail[0])
    if kind == Nodetype.NAME:
        return rand_message(store, rng, detail)
    sub, count = detail
    n = count if kind == Nodetype.ARRAY else rng.randint(0, 4)
    items = [rand_value(store, rng, sub) for _ in range(n)]
    if sub[0] == Nodetype.BASE and sub[1][0] in NUMPY_TYPES:
        return np.array(items, dtype=NUMPY_TYPES[sub[1][0]])
    return items


def rand_message(store, rng: random.Random, typename: str) -> Any:
    cls = store.types[typename]
    _, fields = store.fielddefs[typename]
    return cls(**{name: rand_value(store, rng, desc) for name, desc in fields})


def to_json(store, value: Any) -> Any:
    """rosbags message (or part of one) as plain JSON values, fields in .msg order."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, (list, tuple)):
        return [to_json(store, v) for v in value]
    if isinstance(value, (bool, int, float, str)) or value is None:
        return value
    if isinstance(value, np.generic):
        return value.item()
    msgtype = getattr(value, '__msgtype__', None)
    if msgtype is None:
        raise TypeError(f'cannot convert {type(value)}')
    # The dataclass also carries the constants and __msgtype__; only fielddefs are fields.
    _, fields = store.fielddefs[msgtype]
    return {name: to_json(store, getattr(value, name)) for name, _ in fields}


def normalise_fields(fields) -> list:
    """Field list with array/sequence details made comparable."""
    return [(name, repr(desc)) for name, desc in fields]


def main() -> int:
    codec = sys.argv[1]
    seed = int(sys.argv[2]) if len(sys.argv) > 2 else 20241122
    rng = random.Random(seed)
    problems: list[str] = []

    types = run_codec(codec, 'types')
    print(f'rust registry: {len(types)} message types')

    # 1. Our own .msg texts, alone, into an empty store.
    ours = get_typestore(Stores.EMPTY)
    for t in types:
        ours.register(get_types_from_msg(t['msg'], t['type']))
    print(f'rosbags parsed {len(types)} .msg texts')

    # 2. Standard types equal rosbags' Jazzy store.
    jazzy = get_typestore(Stores.ROS2_JAZZY)
    std = [t['type'] for t in types if not t['type'].startswith('cowork_msgs/')]
    for name in std:
        if name not in jazzy.fielddefs:
            problems.append(f'{name}: not in rosbags ROS2_JAZZY store')
            continue
        a_consts, a_fields = ours.fielddefs[name]
        b_consts, b_fields = jazzy.fielddefs[name]
        if normalise_fields(a_fields) != normalise_fields(b_fields) or list(a_consts) != list(b_consts):
            problems.append(f'{name}: differs from ROS2_JAZZY\n  ours:  {a_fields} {a_consts}\n  jazzy: {b_fields} {b_consts}')
    print(f'{len(std)} standard types compared with rosbags ROS2_JAZZY field definitions')

    # 3. Full definitions parse and agree; constants agree with Rust.
    sections = 0
    for t in types:
        parsed = get_types_from_msg(t['definition'], t['type'])
        sections += len(parsed)
        for name, (consts, fields) in parsed.items():
            o_consts, o_fields = ours.fielddefs.get(name, (None, None))
            if o_fields is None or normalise_fields(fields) != normalise_fields(o_fields) or list(consts) != list(o_consts):
                problems.append(f"{t['type']}: definition section {name} differs from its .msg")
        rust_consts = [(n, v.strip('"')) for n, _, v in t['constants']]
        msg_consts = [(n, str(v) if not isinstance(v, bool) else str(v).lower()) for n, _, v in ours.fielddefs[t['type']][0]]
        if rust_consts != msg_consts:
            problems.append(f"{t['type']}: constants Rust {rust_consts} != rosbags {msg_consts}")
    print(f'{len(types)} full ros2msg definitions parsed ({sections} type sections)')

    # 4. CDR bytes, both directions.
    samples_per_type = 8
    items, values, py_bytes = [], [], []
    for t in types:
        for _ in range(samples_per_type):
            msg = rand_message(ours, rng, t['type'])
            raw = bytes(ours.serialize_cdr(msg, t['type']))
            items.append({'type': t['type'], 'value': to_json(ours, msg)})
            values.append(msg)
            py_bytes.append(raw)
    encoded = run_codec(codec, 'encode', items)
    decoded = run_codec(codec, 'decode', [{'type': it['type'], 'cdr_hex': b.hex()} for it, b in zip(items, py_bytes)])
    equal_bytes = 0
    total_bytes = 0
    for item, raw, enc, dec in zip(items, py_bytes, encoded, decoded):
        rust_raw = bytes.fromhex(enc['cdr_hex'])
        total_bytes += len(rust_raw)
        if rust_raw == raw:
            equal_bytes += 1
        else:
            problems.append(f"{item['type']}: CDR differs\n  rosbags: {raw.hex()}\n  rust:    {rust_raw.hex()}\n  value: {json.dumps(item['value'])}")
            continue
        back = to_json(ours, ours.deserialize_cdr(rust_raw, item['type']))
        if back != item['value']:
            problems.append(f"{item['type']}: rosbags decodes Rust bytes to a different value")
        if dec['value'] != item['value']:
            problems.append(f"{item['type']}: Rust decodes rosbags bytes to {json.dumps(dec['value'])}, expected {json.dumps(item['value'])}")
    print(f'CDR: {equal_bytes}/{len(items)} samples byte-identical ({total_bytes} bytes, '
          f'{samples_per_type} random samples per type, seed {seed}); decoded both ways')

    # Big-endian payloads from rosbags decode too.
    be_ok = 0
    for item, msg in list(zip(items, values))[::samples_per_type]:
        raw_be = bytes(ours.serialize_cdr(msg, item['type'], little_endian=False))
        dec = run_codec(codec, 'decode', [{'type': item['type'], 'cdr_hex': raw_be.hex()}])[0]
        if dec['value'] == item['value']:
            be_ok += 1
        else:
            problems.append(f"{item['type']}: big-endian payload decodes differently")
    print(f'CDR big-endian: {be_ok}/{len(types)} types decode to the same values')

    for p in problems[:20]:
        print('MISMATCH', p)
    if problems:
        print(f'{len(problems)} mismatches')
        return 1
    print('msgs crosscheck: all agree')
    return 0


if __name__ == '__main__':
    sys.exit(main())
