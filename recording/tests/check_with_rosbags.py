#!/usr/bin/env python3
"""Reads a recording written by rsrio's recorder with Debian's python3-rosbags.

usage: check_with_rosbags.py WRITE_SAMPLE_RECORDING WORK_DIR

Runs the writer (tests/write_sample_recording.cpp) to make WORK_DIR/sample_bag (a rosbag2 bag:
metadata.yaml + one .mcap) and WORK_DIR/expected.json (what it wrote), then:

1. checks the MCAP structure with nothing but the spec and zlib (magic, header profile, chunk,
   data-section and summary CRCs, message indexes, summary offsets, statistics): independent of
   our C++ reader, which shares the writer's understanding of the format;
2. opens the bag with rosbags' AnyReader, which builds its types from the schemas embedded in the
   file (no ROS installation), and checks topics, types, counts and every compared field value.
"""

import json
import shutil
import struct
import subprocess
import sys
import zlib
from collections import defaultdict
from pathlib import Path

MAGIC = b'\x89MCAP0\r\n'


def fail(message):
    print(f'FAIL: {message}', file=sys.stderr)
    sys.exit(1)


def check(condition, message):
    if not condition:
        fail(message)


class Cursor:
    """Little-endian reads from bytes."""

    def __init__(self, data, at=0):
        self.data = data
        self.at = at

    def take(self, fmt):
        values = struct.unpack_from('<' + fmt, self.data, self.at)
        self.at += struct.calcsize('<' + fmt)
        return values if len(values) > 1 else values[0]

    def string(self):
        length = self.take('I')
        text = self.data[self.at:self.at + length]
        self.at += length
        return text.decode()


def records(data, start, end):
    """(opcode, offset, content bytes) of the records in data[start:end]."""
    at = start
    while at < end:
        opcode, length = struct.unpack_from('<BQ', data, at)
        yield opcode, at, data[at + 9:at + 9 + length]
        at += 9 + length


def check_mcap_structure(path, expected_message_count):
    data = path.read_bytes()
    check(data[:8] == MAGIC and data[-8:] == MAGIC, 'magic at both ends')

    opcode, length = struct.unpack_from('<BQ', data, 8)
    check(opcode == 0x01, 'first record is the header')
    header = Cursor(data, 17)
    profile, library = header.string(), header.string()
    check(profile == 'ros2', f'profile ros2, got {profile!r}')
    check(library.startswith('rsrio '), f'library "rsrio <version>", got {library!r}')

    # Data section.
    at = 17 + length
    chunks = 0
    messages = 0
    pending_index = None  # message records of the last chunk, by channel: {channel: [(log_time, offset)]}
    seen_index_channels = set()
    data_end_at = None
    while data_end_at is None:
        opcode, length = struct.unpack_from('<BQ', data, at)
        content = data[at + 9:at + 9 + length]
        if opcode == 0x06:  # chunk
            if pending_index is not None:
                check(seen_index_channels == set(pending_index), 'one message index per channel after a chunk')
            c = Cursor(content)
            start_time, end_time, uncompressed_size, crc = c.take('QQQI')
            compression = c.string()
            records_length = c.take('Q')
            chunk_records = content[c.at:c.at + records_length]
            check(compression == '', 'uncompressed chunks')
            check(uncompressed_size == records_length, 'chunk uncompressed size')
            check(crc == zlib.crc32(chunk_records), f'chunk CRC at {at}')
            pending_index = defaultdict(list)
            seen_index_channels = set()
            times = []
            for inner_opcode, inner_at, inner in records(chunk_records, 0, len(chunk_records)):
                if inner_opcode == 0x05:
                    channel, _, log_time, _ = struct.unpack_from('<HIQQ', inner, 0)
                    pending_index[channel].append((log_time, inner_at))
                    times.append(log_time)
                    messages += 1
            if times:
                check((start_time, end_time) == (min(times), max(times)), 'chunk message times')
            chunks += 1
        elif opcode == 0x07:  # message index
            c = Cursor(content)
            channel = c.take('H')
            entries = [c.take('QQ') for _ in range(c.take('I') // 16)]
            check(entries == pending_index.get(channel), f'message index of channel {channel} at {at}')
            seen_index_channels.add(channel)
        elif opcode == 0x0F:  # data end
            data_end_at = at
            check(struct.unpack_from('<I', content)[0] == zlib.crc32(data[:at]), 'data section CRC')
        at += 9 + length
    check(messages == expected_message_count, f'{expected_message_count} messages in chunks, found {messages}')

    # Footer and summary.
    footer_at = len(data) - 8 - 29
    opcode, length, summary_start, summary_offset_start, summary_crc = struct.unpack_from('<BQQQI', data, footer_at)
    check((opcode, length) == (0x02, 20), 'footer record before the closing magic')
    check(summary_start == at, 'summary starts after the data end record')
    check(summary_crc == zlib.crc32(data[summary_start:footer_at + 25]), 'summary CRC')
    groups = {}
    for opcode, _, content in records(data, summary_offset_start, footer_at):
        check(opcode == 0x0E, 'only summary offsets between the summary and the footer')
        group, start, length = struct.unpack_from('<BQQ', content)
        groups[group] = (start, length)
        for inner_opcode, _, _ in records(data, start, start + length):
            check(inner_opcode == group, f'summary group {group:#x} holds only its opcode')
    check(set(groups) == {0x03, 0x04, 0x08, 0x0B, 0x0D}, f'summary groups, got {sorted(groups)}')
    chunk_indexes = 0
    for opcode, _, content in records(data, summary_start, summary_offset_start):
        if opcode == 0x0B:
            check(struct.unpack_from('<Q', content)[0] == expected_message_count, 'statistics message count')
        if opcode == 0x08:
            chunk_indexes += 1
            chunk_offset = struct.unpack_from('<Q', content, 16)[0]
            check(data[chunk_offset] == 0x06, 'chunk index points at a chunk')
    check(chunk_indexes == chunks, 'one chunk index per chunk')
    print(f'MCAP structure ok: {chunks} chunks, {messages} messages, CRCs verified with zlib')


def compare(expected, actual, where):
    if isinstance(expected, dict):
        for key, value in expected.items():
            if key == 'adc':
                adc = bytes(actual.adc)
                check(len(adc) == value['length'], f'{where}.adc length')
                check(list(adc[:len(value['head'])]) == value['head'], f'{where}.adc head')
                check(sum(adc) == value['sum'], f'{where}.adc byte sum')
                continue
            check(hasattr(actual, key), f'{where}: rosbags type has no field {key!r}')
            compare(value, getattr(actual, key), f'{where}.{key}')
    elif isinstance(expected, list):
        check(len(actual) == len(expected), f'{where}: {len(expected)} elements, got {len(actual)}')
        for index, (e, a) in enumerate(zip(expected, actual)):
            compare(e, a, f'{where}[{index}]')
    else:
        if isinstance(expected, float):
            check(float(actual) == expected, f'{where}: expected {expected!r}, got {actual!r}')
        else:
            check(actual == expected, f'{where}: expected {expected!r}, got {actual!r}')


def check_with_rosbags(bag, expected):
    from rosbags.highlevel import AnyReader
    from rosbags.interfaces import MessageDefinitionFormat

    wanted = {(m['topic'], m['index']): m for m in expected['messages']}
    compared = set()
    counts = defaultdict(int)
    with AnyReader([bag]) as reader:
        topics = reader.topics
        check(set(topics) == set(expected['topics']), f'topics {sorted(topics)}')
        for name, info in expected['topics'].items():
            check(topics[name].msgtype == info['type'], f'{name}: type {topics[name].msgtype}')
            check(topics[name].msgcount == info['count'], f'{name}: count {topics[name].msgcount}')
        for connection in reader.connections:
            # The schema embedded in the MCAP file, not a built-in type store.
            check(connection.msgdef.format == MessageDefinitionFormat.MSG and connection.msgdef.data,
                  f'{connection.topic}: embedded ros2msg schema')

        for connection, timestamp, rawdata in reader.messages():
            index = counts[connection.topic]
            counts[connection.topic] += 1
            message = reader.deserialize(rawdata, connection.msgtype)  # every message must decode
            if (connection.topic, index) in wanted:
                entry = wanted[(connection.topic, index)]
                check(timestamp == entry['log_time'], f'{connection.topic}[{index}] log time')
                compare(entry['fields'], message, f'{connection.topic}[{index}]')
                compared.add((connection.topic, index))

    for name, info in expected['topics'].items():
        check(counts[name] == info['count'], f'{name}: rosbags returned {counts[name]} of {info["count"]} messages')
    check(compared == set(wanted), f'compared {sorted(compared)} of {sorted(wanted)}')
    types = sorted({m['topic'] for m in expected['messages']})
    print(f'rosbags ok: {sum(counts.values())} messages decoded, {len(compared)} compared field by field '
          f'on {", ".join(types)}')


def main():
    if len(sys.argv) != 3:
        print(__doc__, file=sys.stderr)
        return 2
    writer, workdir = sys.argv[1], Path(sys.argv[2])
    if workdir.exists():
        shutil.rmtree(workdir)
    workdir.mkdir(parents=True)
    bag = workdir / 'sample_bag'
    expected_path = workdir / 'expected.json'
    subprocess.run([writer, str(bag), str(expected_path)], check=True)
    expected = json.loads(expected_path.read_text())
    check((bag / 'metadata.yaml').is_file(), 'the writer made a rosbag2 bag directory')

    total = sum(info['count'] for info in expected['topics'].values())
    check_mcap_structure(bag / expected['mcap'], total)
    check_with_rosbags(bag, expected)
    return 0


if __name__ == '__main__':
    sys.exit(main())
