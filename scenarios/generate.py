#!/usr/bin/env python3
"""Writes the five Table I scenarios, scenarios/seq*.yaml: the office floor (sequences 2-5) and the
meeting room (sequence 1). The floor plan is shared by four files, so edit it here and rerun:

    python3 scenarios/generate.py

then check the lengths and durations against the paper (sim/tests/scenario_test.cpp does) and
update the table in scenarios/README.md. Walking speeds can be tried out without editing, e.g.
`python3 scenarios/generate.py s3=0.65` (keys s1..s5: speed of sequence N; p1: corner pause of
sequence 1).
"""
import os
import sys

OUT = os.path.dirname(os.path.abspath(__file__))

def fmt(v):
    if isinstance(v, bool): return 'true' if v else 'false'
    if isinstance(v, int): return str(v)
    if isinstance(v, float):
        s = f'{v:.3f}'.rstrip('0')
        return s + '0' if s.endswith('.') else s
    if isinstance(v, (list, tuple)): return '[' + ', '.join(fmt(x) for x in v) + ']'
    return str(v)

def flat(points):
    return [float(c) for p in points for c in p]

def points_block(key, pts, indent, per_line=4):
    vals = flat(pts)
    lines = []
    pad = ' ' * indent
    chunks = [vals[i:i + 2 * per_line] for i in range(0, len(vals), 2 * per_line)]
    lines.append(f'{pad}{key}: [' + ', '.join(fmt(x) for x in chunks[0]) + (',' if len(chunks) > 1 else ']'))
    for i, c in enumerate(chunks[1:]):
        last = i == len(chunks) - 2
        lines.append(pad + ' ' * (len(key) + 3) + ', '.join(fmt(x) for x in c) + (']' if last else ','))
    return lines

def common_header(name, desc, seed):
    return [
        '%YAML:1.0', '---',
        f'# {desc}',
        '# Written by scenarios/generate.py (edit the floor plan there); schema in scenarios/README.md.',
        f'name: {name}',
        f'description: "{desc}"',
        f'seed: {seed}',
        'start_time_unix_s: 1700000000.0',
        '',
        'radar:',
        '  preset: mmwcas',
        '  frame_period_ms: 100.0',
        '',
        'radar_model:',
        '  tx_power_dbm: 12.0',
        '  noise_figure_db: 12.0',
        '  noise_rms_lsb: 10.0',
        '  azimuth_beamwidth_deg: 120.0',
        '  elevation_beamwidth_deg: 30.0',
        '  if_highpass_khz: 175.0',
        '  leakage_amplitude_lsb: 20.0',
        '',
        'rig:',
        '  height_m: 1.0',
        '  radar_translation_m: [0.03, 0.0, -0.07]',
        '  radar_rpy_deg: [0.0, 0.0, 0.0]',
        '  imu_time_offset_s: 0.004',
        '',
        'imu:',
        '  rate_hz: 200.0',
        '',
    ]

def trajectory(waypoints, speed, pauses=None, seg_speeds=None, still_start=3.0, still_end=2.0, knot=0.8):
    L = ['trajectory:']
    L += points_block('waypoints', waypoints, 2)
    L.append(f'  speed_mps: {fmt(speed)}')
    if seg_speeds: L.append(f'  segment_speeds_mps: {fmt(seg_speeds)}')
    if pauses: L.append(f'  pauses_s: {fmt(pauses)}')
    L += [f'  knot_interval_s: {fmt(knot)}', '  turn_distance_m: 0.7',
          f'  still_start_s: {fmt(still_start)}', f'  still_end_s: {fmt(still_end)}',
          '  bob_amplitude_m: 0.012', '  roll_amplitude_deg: 0.8', '  pitch_amplitude_deg: 0.6',
          '  step_frequency_hz: 1.8', '']
    return L

def scene(walls, boxes, pillars, clutter, people, seed=1):
    L = ['scene:', f'  seed: {seed}', '  multipath_max_distance_m: 5.0',
         '  wall_defaults:', '    height_m: 2.8', '    spacing_m: 0.25', '    row_spacing_m: 0.5',
         '    rcs_m2: 0.02', '    jitter_m: 0.03', '    incidence_exponent: 2.0']
    L.append('  walls:')
    for name, w in walls:
        L.append(f'    {name}:')
        L += points_block('points', w['points'], 6)
        for k in ('closed', 'height_m', 'rcs_m2', 'mirror_loss_db'):
            if k in w: L.append(f'      {k}: {fmt(w[k])}')
    if boxes:
        L.append('  boxes:')
        for name, b in boxes:
            L.append(f'    {name}: {{center: {fmt(b["center"])}, size_m: {fmt(b["size"])}, yaw_deg: {fmt(float(b.get("yaw", 0.0)))}, '
                     f'rcs_m2: {fmt(b.get("rcs", 0.03))}, corner_rcs_m2: {fmt(b.get("corner", 0.2))}}}')
    if pillars:
        L.append('  pillars:')
        for name, p in pillars:
            L.append(f'    {name}: {{center: {fmt(p["center"])}, radius_m: {fmt(p["r"])}, height_m: {fmt(p.get("h", 2.8))}, rcs_m2: {fmt(p.get("rcs", 0.05))}}}')
    if clutter:
        L.append('  clutter:')
        for name, c in clutter:
            L.append(f'    {name}: {{region: {fmt(c["region"])}, count: {c["count"]}, z_range_m: {fmt(c["z"])}, rcs_m2: {fmt(c["rcs"])}}}')
    if people:
        L.append('  people:')
        for name, p in people:
            L.append(f'    {name}:')
            L += points_block('path', p['path'], 6)
            for k in ('speed_mps', 'loop', 'start_s', 'pause_s', 'height_m', 'rcs_m2'):
                if k in p: L.append(f'      {k}: {fmt(p[k])}')
    return L

# ---------------------------------------------------------------- office floor (seq2..5)
# Corridor centrelines: a ring (0,0)-(50,22.3) and cross corridors at x = 8.5 and x = 22.2.
# Corridors are 2.4 m wide; the blocks between them are solid (rooms are not entered).
W, H, XS, XM, HW = 50.0, 22.3, 8.5, 22.2, 1.2
def rect(x0, y0, x1, y1): return [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
def office():
    walls = [
        ('outer_south_glass', {'points': [(-HW, -HW), (W + HW, -HW)], 'mirror_loss_db': 8.0, 'rcs_m2': 0.01}),
        ('outer_east', {'points': [(W + HW, -HW), (W + HW, H + HW)]}),
        ('outer_north', {'points': [(W + HW, H + HW), (-HW, H + HW)]}),
        ('outer_west', {'points': [(-HW, H + HW), (-HW, -HW)]}),
        ('block_west', {'points': rect(HW, HW, XS - HW, H - HW), 'closed': True}),
        ('block_middle', {'points': rect(XS + HW, HW, XM - HW, H - HW), 'closed': True}),
        ('block_east', {'points': rect(XM + HW, HW, W - HW, H - HW), 'closed': True}),
    ]
    boxes = [
        ('bench_south_1', {'center': (14.0, -0.95), 'size': (1.6, 0.45, 0.45)}),
        ('bench_south_2', {'center': (36.0, -0.95), 'size': (1.6, 0.45, 0.45)}),
        ('cabinet_east', {'center': (W + 0.95, 8.0), 'size': (0.45, 1.0, 1.8), 'rcs': 0.05, 'corner': 0.4}),
        ('printer_north', {'center': (30.0, H + 0.9), 'size': (0.6, 0.6, 1.1), 'rcs': 0.05, 'corner': 0.5}),
        ('bin_west', {'center': (-0.9, 10.0), 'size': (0.4, 0.4, 0.7), 'corner': 0.3}),
        ('bin_cross', {'center': (XS - 0.9, 15.0), 'size': (0.4, 0.4, 0.7), 'corner': 0.3}),
        ('shelf_middle', {'center': (XM + 0.95, 6.0), 'size': (0.45, 1.2, 1.6), 'rcs': 0.04, 'corner': 0.4}),
        ('water_north', {'center': (4.0, H + 0.95), 'size': (0.4, 0.4, 1.2), 'corner': 0.5}),
        ('sofa_east', {'center': (W - 0.9, 15.0), 'size': (0.6, 1.8, 0.8), 'rcs': 0.03}),
    ]
    pillars = [(f'column_south_{i}', {'center': (x, -HW + 0.2), 'r': 0.2}) for i, x in enumerate([6.0, 18.0, 30.0, 42.0])]
    pillars += [(f'column_north_{i}', {'center': (x, H + HW - 0.2), 'r': 0.2}) for i, x in enumerate([12.0, 26.0, 40.0])]
    clutter = []
    # Door frames along the block walls (vertical strips of strong points) and floor clutter.
    doors = [((XS - HW), 5.0, 'x'), ((XS - HW), 17.0, 'x'), ((XS + HW), 11.0, 'x'), ((XM - HW), 4.0, 'x'),
             ((XM - HW), 16.0, 'x'), ((XM + HW), 9.0, 'x'), ((W - HW), 12.0, 'x'), (HW, 8.0, 'x'),
             (4.0, HW, 'y'), (15.0, HW, 'y'), (28.0, HW, 'y'), (38.0, HW, 'y'), (46.0, HW, 'y'),
             (5.0, H - HW, 'y'), (16.0, H - HW, 'y'), (33.0, H - HW, 'y'), (44.0, H - HW, 'y')]
    for i, (a, b, axis) in enumerate(doors):
        for j, off in enumerate((-0.45, 0.45)):
            if axis == 'x': x, y = a, b + off
            else: x, y = a + off, b
            clutter.append((f'door_{i}_{j}', {'region': [x - 0.02, y - 0.02, x + 0.02, y + 0.02], 'count': 4, 'z': [0.1, 2.1], 'rcs': 0.08}))
    corridors = [(-HW, -HW, W + HW, HW), (-HW, H - HW, W + HW, H + HW), (-HW, -HW, HW, H + HW),
                 (XS - HW, -HW, XS + HW, H + HW), (XM - HW, -HW, XM + HW, H + HW), (W - HW, -HW, W + HW, H + HW)]
    for i, (x0, y0, x1, y1) in enumerate(corridors):
        area = (x1 - x0) * (y1 - y0)
        clutter.append((f'floor_{i}', {'region': [x0, y0, x1, y1], 'count': int(area / 3), 'z': [0.0, 0.05], 'rcs': 0.003}))
        clutter.append((f'fixtures_{i}', {'region': [x0, y0, x1, y1], 'count': int(area / 12), 'z': [2.4, 2.8], 'rcs': 0.02}))
    people = [
        ('walker_south', {'path': [(3.0, 0.4), (47.0, 0.4)], 'speed_mps': 1.25, 'start_s': 5.0, 'pause_s': 4.0}),
        ('walker_cross', {'path': [(XS + 0.4, 1.5), (XS + 0.4, 21.0)], 'speed_mps': 1.1, 'start_s': 20.0, 'pause_s': 6.0}),
        ('walker_north', {'path': [(48.0, H - 0.4), (2.0, H - 0.4)], 'speed_mps': 1.35, 'start_s': 40.0, 'pause_s': 3.0}),
        ('walker_east', {'path': [(W - 0.4, 2.0), (W - 0.4, 20.0)], 'speed_mps': 0.9, 'start_s': 60.0, 'pause_s': 8.0}),
    ]
    return scene(walls, boxes, pillars, clutter, people)

def write(name, desc, seed, traj_lines, scene_lines):
    text = '\n'.join(common_header(name, desc, seed) + traj_lines + scene_lines) + '\n'
    with open(os.path.join(OUT, name + '.yaml'), 'w') as f: f.write(text)

SMALL = [(XS, 0.0), (XS, H), (0.0, H), (0.0, 0.0)]
MEDIUM = [(XM, 0.0), (XM, H), (0.0, H), (0.0, 0.0)]
LARGE = [(W, 0.0), (W, H), (0.0, H), (0.0, 0.0)]

v = {k: float(x) for k, x in (a.split('=') for a in sys.argv[1:])}

# seq2: the small loop once, then along the south corridor and back to the start.
wp = [(4.0, 0.0)] + SMALL + [(19.15, 0.0), (4.0, 0.0)]
pauses = [0.0] * len(wp); pauses[-2] = 3.0
write('seq2_small_loop', 'Sequence 2, Small Loop (paper Table I: 91.89 m, 157.98 s): the west loop of the office floor, then down the south corridor and back.',
      2, trajectory(wp, v.get('s2', 0.635), pauses), office())
# seq3: the large ring once.
wp = [(2.0, 0.0)] + LARGE + [(2.0, 0.0)]
write('seq3_large_loop', 'Sequence 3, Large Loop (paper Table I: 144.59 m, 232.74 s): once round the outer corridor ring.',
      3, trajectory(wp, v.get('s3', 0.64)), office())
# seq4: small loop, then the large ring.
wp = [(2.0, 0.0)] + SMALL + [(2.0, 0.0)] + LARGE + [(2.0, 0.0)]
write('seq4_small_large_loop', 'Sequence 4, Small + Large Loop (paper Table I: 206.12 m, 263.19 s): the west loop, then the outer ring.',
      4, trajectory(wp, v.get('s4', 0.80)), office())
# seq5: medium loop, then the large ring.
wp = [(2.0, 0.0)] + MEDIUM + [(2.0, 0.0)] + LARGE + [(2.0, 0.0)]
write('seq5_medium_large_loop', 'Sequence 5, Medium + Large Loop (paper Table I: 233.54 m, 320.06 s): the west and middle loop, then the outer ring.',
      5, trajectory(wp, v.get('s5', 0.75)), office())

# ---------------------------------------------------------------- meeting room (seq1)
RW, RH = 9.0, 7.0
walls = [
    ('room', {'points': [(0.0, 0.0), (RW, 0.0), (RW, RH), (0.0, RH)], 'height_m': 2.7}),
    ('glass_wall', {'points': [(0.0, RH), (0.0, 0.0)], 'height_m': 2.7, 'mirror_loss_db': 6.0, 'rcs_m2': 0.01}),
]
boxes = [('table', {'center': (4.5, 3.5), 'size': (4.0, 1.4, 0.75), 'rcs': 0.04, 'corner': 0.6})]
for i, x in enumerate([3.0, 4.0, 5.0, 6.0]):
    boxes.append((f'chair_s{i}', {'center': (x, 2.3), 'size': (0.48, 0.48, 0.9), 'yaw': 5.0 * (i - 1.5), 'rcs': 0.03, 'corner': 0.15}))
    boxes.append((f'chair_n{i}', {'center': (x, 4.7), 'size': (0.48, 0.48, 0.9), 'yaw': -4.0 * (i - 1.5), 'rcs': 0.03, 'corner': 0.15}))
boxes += [('chair_w', {'center': (2.05, 3.5), 'size': (0.48, 0.48, 0.9), 'rcs': 0.03, 'corner': 0.15}),
          ('chair_e', {'center': (6.95, 3.5), 'size': (0.48, 0.48, 0.9), 'rcs': 0.03, 'corner': 0.15}),
          ('cabinet', {'center': (8.75, 2.2), 'size': (0.45, 2.0, 1.9), 'rcs': 0.05, 'corner': 0.5}),
          ('sideboard', {'center': (4.5, 6.75), 'size': (2.4, 0.45, 0.9), 'rcs': 0.04, 'corner': 0.4})]
pillars = [('column', {'center': (8.45, 6.45), 'r': 0.25})]
clutter = [('screen', {'region': [8.9, 4.2, 8.95, 5.6], 'count': 12, 'z': [1.0, 1.8], 'rcs': 0.05}),
           ('door_frame_a', {'region': [6.5, 0.02, 6.52, 0.04], 'count': 5, 'z': [0.1, 2.1], 'rcs': 0.08}),
           ('door_frame_b', {'region': [7.45, 0.02, 7.47, 0.04], 'count': 5, 'z': [0.1, 2.1], 'rcs': 0.08}),
           ('floor', {'region': [0.2, 0.2, 8.8, 6.8], 'count': 25, 'z': [0.0, 0.05], 'rcs': 0.003}),
           ('table_items', {'region': [2.8, 3.0, 6.2, 4.0], 'count': 10, 'z': [0.76, 0.9], 'rcs': 0.01}),
           ('ceiling_lights', {'region': [1.0, 1.0, 8.0, 6.0], 'count': 8, 'z': [2.6, 2.7], 'rcs': 0.03})]
people = [('colleague', {'path': [(0.9, 6.3), (7.6, 6.3)], 'speed_mps': 0.8, 'start_s': 25.0, 'pause_s': 12.0}),
          ('visitor', {'path': [(7.0, 0.6), (8.3, 0.6), (8.3, 1.2)], 'speed_mps': 0.6, 'start_s': 70.0, 'pause_s': 20.0})]
loop = [(1.35, 1.35), (7.65, 1.35), (7.65, 5.65), (1.35, 5.65)]
wp = [(1.35, 2.6)] + loop + loop + [(1.35, 2.6)]
pauses = [0.0] + [v.get('p1', 3.0)] * 8 + [0.0]
write('seq1_meeting_room', 'Sequence 1, Meeting Room (paper Table I: 42.46 m, 141.07 s): twice round the table, stopping to look around at the corners.',
      1, trajectory(wp, v.get('s1', 0.42), pauses, knot=0.6), scene(walls, boxes, pillars, clutter, people))
