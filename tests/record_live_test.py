#!/usr/bin/env python3
"""rsrio-record against rsrio-dca1000-emu: real processes, real UDP sockets on loopback, the
recording read back with Debian's python3-rosbags.

usage: record_live_test.py EMU RECORD SIM PUBLISH_IMU WORK_DIR {duration|sigterm}

duration: a 20 s recording (--duration 20) of a fault-free stream. Every frame the emulator sent
  is in the file, numbered without a gap, undamaged, and byte for byte the frame rsrio-sim makes
  for the same scenario (the simulator is the ground truth of what went over the wire).
sigterm:  a stream with loss, reordering and duplicates, and a 200 Hz sensor_msgs/Imu over DDS
  (publish_imu, --imu-topic), the recorder stopped by SIGTERM after a few seconds. The IMU samples
  are in the file in order. It exits 0 and leaves a complete file: rosbags opens it (it needs the summary and
  index), the frame and damage counts match what the recorder reported, damaged frames carry
  FLAG_DAMAGED and lost_bytes, and every frame not flagged is exactly the simulator's frame.
"""

import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

SCENARIO = 'scenarios/test_tiny.yaml'
FLAG_DAMAGED = 1


def fail(message):
    print(f'FAIL: {message}', file=sys.stderr)
    sys.exit(1)


def check(condition, message):
    if not condition:
        fail(message)


def counters(text, prefix):
    """key=value pairs of the line starting with prefix."""
    for line in text.splitlines():
        if line.startswith(prefix):
            return {k: int(v) for k, v in re.findall(r'(\w+)=(\d+)', line)}
    fail(f'no "{prefix}" line in:\n{text}')


def read_bag(bag_dir, topic):
    from rosbags.highlevel import AnyReader
    frames = []
    with AnyReader([bag_dir]) as reader:
        connections = [c for c in reader.connections if c.topic == topic]
        check(connections, f'topic {topic} in {bag_dir}')
        for connection, _, rawdata in reader.messages(connections=connections):
            m = reader.deserialize(rawdata, connection.msgtype)
            frames.append((int(m.frame_number), int(m.flags), int(m.lost_bytes), bytes(m.adc), int(m.config.loops)))
    return frames


def read_imu(bag_dir):
    """The publication index (angular_velocity.x) of every /imu sample."""
    from rosbags.highlevel import AnyReader
    with AnyReader([bag_dir]) as reader:
        connections = [c for c in reader.connections if c.topic == '/imu']
        check(connections, f'topic /imu in {bag_dir}')
        return [int(reader.deserialize(raw, c.msgtype).angular_velocity.x)
                for c, _, raw in reader.messages(connections=connections)]


def simulator_frames(sim, work):
    """The raw frames rsrio-sim makes for the scenario (the emulator streams these, repeated)."""
    out = work / 'sim_bag' / 'sim_0.mcap'
    out.parent.mkdir()
    subprocess.run([sim, '--scenario', SCENARIO, '--out', str(out), '--rosbag2'], check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, timeout=300)
    frames = read_bag(out.parent, '/radar/raw')
    check(frames and [f[0] for f in frames] == list(range(len(frames))), 'rsrio-sim frames numbered 0..N-1')
    return [f[3] for f in frames]


def main():
    if len(sys.argv) != 7 or sys.argv[6] not in ('duration', 'sigterm'):
        fail(__doc__)
    emu, record, sim, publish_imu, work, mode = sys.argv[1:]
    work = Path(work) / mode
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    truth = simulator_frames(sim, work)

    # Addresses of our own in 127.0.0.0/8, so that parallel runs (ctest -j, several builds) do not
    # meet on the DCA1000's fixed ports.
    tag = os.getpid() % 65000
    board = f'127.{77 if mode == "duration" else 78}.{tag >> 8}.{tag & 255}'
    host = f'127.{79 if mode == "duration" else 80}.{tag >> 8}.{tag & 255}'
    config = work / 'record.yaml'
    config.write_text('radar:\n  preset: xwr1843\n  loops: 16\n  frame_period_ms: 100.0\n'
                      f'dca1000:\n  host: "{host}"\n')
    faults = [] if mode == 'duration' else ['--loss', '0.001', '--reorder', '0.01', '--duplicate', '0.01',
                                            '--seed', '5']
    emulator = subprocess.Popen([emu, '--scenario', SCENARIO, '--address', f'{board}:4096',
                                 '--host-data', f'{host}:4098', *faults],
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    imu_publisher = None
    imu_args = []
    if mode == 'sigterm':
        os.environ['ROS_DOMAIN_ID'] = str(60 + tag % 40)  # a DDS domain of this run's own (runtime/tests/daemon_end_to_end.sh lists the ranges)
        imu_topic = f'rt/rsrio_test/imu_{tag}'
        imu_publisher = subprocess.Popen([publish_imu, imu_topic, '200'], stdout=subprocess.PIPE, text=True)
        imu_args = ['--imu-topic', imu_topic]
    bag = work / 'bag'
    recorder_cmd = [record, '--source', f'dca1000://{board}', '--out', str(bag / 'live_0.mcap'), '--rosbag2',
                    '--config', str(config), *imu_args]
    try:
        if mode == 'duration':
            recorder = subprocess.run([*recorder_cmd, '--duration', '20'], capture_output=True, text=True, timeout=120)
        else:
            recorder = subprocess.Popen(recorder_cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            time.sleep(4.0)
            check(recorder.poll() is None, 'the recorder is still running before SIGTERM')
            recorder.send_signal(signal.SIGTERM)
            out, err = recorder.communicate(timeout=60)
            recorder = subprocess.CompletedProcess(recorder.args, recorder.returncode, out, err)
    finally:
        emulator.send_signal(signal.SIGTERM)
        emu_out, emu_err = emulator.communicate(timeout=60)
        if imu_publisher:
            imu_publisher.send_signal(signal.SIGTERM)
            imu_publisher.communicate(timeout=60)
    print(recorder.stdout, recorder.stderr[-2000:], emu_out, sep='\n')
    check(recorder.returncode == 0, f'recorder exit code {recorder.returncode}:\n{recorder.stderr}')
    check(emulator.returncode == 0, f'emulator exit code {emulator.returncode}:\n{emu_err}')
    rec = counters(recorder.stdout, 'rsrio-record: wrote')
    sent = counters(emu_out, 'rsrio-dca1000-emu:')
    check(rec['kernel_drops'] == 0 and rec['recorder_drops'] == 0,
          'no datagram dropped by the kernel and no frame by the recorder (else the counts below differ)')

    frames = read_bag(bag, '/radar/raw')
    numbers = [f[0] for f in frames]
    check(len(frames) == rec['frames'], f'rosbags reads {len(frames)} frames, the recorder wrote {rec["frames"]}')
    check(numbers == sorted(numbers) and len(set(numbers)) == len(numbers), 'frame numbers increase')
    check(all(f[4] == 16 for f in frames), 'every frame carries the radar configuration (16 loops)')
    frame_bytes = len(truth[0])
    check(all(len(f[3]) == frame_bytes for f in frames), f'every frame has {frame_bytes} bytes')
    damaged = [f for f in frames if f[1] & FLAG_DAMAGED]
    check(len(damaged) == rec['damaged'], f'{len(damaged)} frames flagged damaged, the recorder counted {rec["damaged"]}')
    check(all(f[2] > 0 for f in damaged), 'damaged frames say how many bytes were zero-filled')
    good = [f for f in frames if not f[1] & FLAG_DAMAGED]
    for number, flags, lost, adc, _ in good:
        check(lost == 0, f'frame {number}: good but lost_bytes {lost}')
        check(adc == truth[number % len(truth)], f'frame {number}: not the simulator\'s frame {number % len(truth)}')

    if mode == 'duration':
        check(numbers == list(range(sent['frames_sent'])),
              f'frames 0..{sent["frames_sent"] - 1} that the emulator sent, got {len(frames)}')
        check(not damaged, 'a fault-free stream gives no damaged frame')
        check(190 <= len(frames) <= 201, f'20 s at 10 Hz is about 200 frames, got {len(frames)}')
    else:
        check(sent['packets_lost'] > 0 and damaged and good, 'both damaged and good frames were recorded')
        # Every frame the emulator sent before STOP_RECORD is in the file, damaged or not (loss of
        # 1 in 1000 packets cannot erase a whole frame of 135 packets).
        check(len(frames) == sent['frames_sent'], f'{len(frames)} frames in the file, {sent["frames_sent"]} sent')
        check(len(frames) >= 20, f'about 40 frames in 4 s, got {len(frames)}')
        imu = read_imu(bag)
        check(len(imu) == rec['imu'], f'rosbags reads {len(imu)} IMU samples, the recorder wrote {rec["imu"]}')
        # ~4 s at 200 Hz, less DDS discovery; best effort on loopback loses none in practice.
        check(len(imu) >= 300, f'IMU samples recorded: {len(imu)}')
        check(imu == sorted(imu) and len(set(imu)) == len(imu), 'IMU samples in publication order, none twice')
    print(f'{mode}: {len(frames)} frames ({len(damaged)} damaged) read with rosbags: OK')


if __name__ == '__main__':
    main()
