#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""Mutational fuzzing of what users hand to `terramrf`: configs, sweeps and input files.

Each case mutates one shipped config or one real input file (docs/robustness.md), runs the CLI on
it and flags any outcome a user should never see:

  * a crash (a signal), a timeout, or an exit status outside 0–4;
  * a sanitizer report (use a build of scripts/sanitize.sh: --bin build-asan/bin/terramrf);
  * a library's own message escaping (yaml-cpp, std::, bad_alloc, vector::_M_range_check …);
  * a config error without a file:line position, or an input error that does not name the file.

Flagged cases are kept, with the command and its output, under WORK/cases/. Python 3 standard
library only. Examples:

  tools/fuzz/fuzz_inputs.py config-validate -n 500
  tools/fuzz/fuzz_inputs.py kitti rellis pcd kitti-object -n 300 --bin build-asan/bin/terramrf
"""
import argparse
import collections
import glob
import os
import random
import re
import shutil
import struct
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
CONFIGS = os.path.join(REPO, 'configs')
RAW_ERROR = re.compile(r'yaml-cpp|bad_alloc|std::|basic_string|stoi|stod|vector::|_M_range_check|'
                       r'terminate called|Aborted|out_of_range')
ODD_VALUES = ['-1', '0', '1e308', '-1e308', 'nan', '.nan', '.inf', '-.inf', '1e9', '2147483648',
              '-2147483649', '99999999999999999999', '""', 'abc', '[]', '{}', '[1, 2]', '{a: 1}',
              '~', 'null', 'true', '0.0001', '1e-12', '3.5', '&a x', '*a', '!!binary aGVsbG8=',
              '0x10', '+5', '[[[[[[1]]]]]]', "'", '"', '{', '[', ':', '|', '%', '@', '`', '1e6',
              '0.001', '/nonexistent/file.yaml', '/dev/null', '/tmp']


class Fuzzer:
    def __init__(self, args):
        self.bin = os.path.abspath(args.bin)
        self.data = os.path.abspath(args.data)
        self.work = args.work or tempfile.mkdtemp(prefix='terramrf_fuzz_')
        os.makedirs(os.path.join(self.work, 'cases'), exist_ok=True)
        self.rng = random.Random(args.seed)
        self.seed = args.seed
        self.timeout = args.timeout
        self.flagged = 0
        self.configs = None

    def config_tree(self):
        """A copy of configs/ in WORK/tree, with WORK/shared/data standing for the data folder:
        mutants sit beside their originals (relative paths such as models/ and
        ../../shared/data hold) without a file written into the source tree."""
        if self.configs is None:
            self.configs = os.path.join(self.work, 'tree', 'configs')
            shutil.rmtree(os.path.join(self.work, 'tree'), ignore_errors=True)
            shutil.copytree(CONFIGS, self.configs)
            shared = os.path.join(self.work, 'shared')
            os.makedirs(shared, exist_ok=True)
            link = os.path.join(shared, 'data')
            # A work folder reused with another --data: the old link would be followed silently.
            if os.path.lexists(link) and os.readlink(link) != self.data:
                os.remove(link)
            if not os.path.lexists(link):
                os.symlink(self.data, link)
            # configs/lcm_replay.yaml, lcm_classify.yaml and sweeps/lcm_layers.yaml read the log
            # configs/lcm_record.yaml writes (out/ of the working folder, the tree here): record
            # it so that they have their log (all five scans: the sweep splits them 0-2 / 3-4).
            tree = os.path.dirname(self.configs)
            rc, out = self.run([self.bin, 'run', 'configs/lcm_record.yaml', '--no-progress',
                                '--out', os.path.join(tree, 'out', 'record')], tree)
            if rc != 0:
                # Not fatal here: lcm_replay.yaml's control case then fails and is flagged, as
                # any seed that cannot run.
                print('fuzz_inputs: configs/lcm_record.yaml failed (%s), so lcm_replay.yaml has '
                      'no log' % rc, file=sys.stderr)
        return self.configs

    # ---- mutations ---------------------------------------------------------------------------
    def edit_lines(self, text, edit, encoding):
        """`text` with one to three random lines edited by `edit(lines, i)`, which returns the
        new list of lines, or bytes to end with."""
        lines = text.split('\n')
        for _ in range(self.rng.randint(1, 3)):
            if not lines:
                lines = ['']
            lines = edit(lines, self.rng.randrange(len(lines)))
            if isinstance(lines, bytes):
                return lines
        return '\n'.join(lines).encode(encoding)

    def mutate_yaml(self, text):
        rng = self.rng

        def edit(lines, i):
            op = rng.random()
            if op < 0.55:  # a value after "key:", block or flow style
                ms = list(re.finditer(r'(\b\w+\s*:\s*)([^,{}\[\]#\n]+|\[[^\]]*\]|\{[^}]*\})',
                                      lines[i]))
                if ms:
                    m = rng.choice(ms)
                    lines[i] = lines[i][:m.start(2)] + rng.choice(ODD_VALUES) + lines[i][m.end(2):]
            elif op < 0.65:
                del lines[i]
            elif op < 0.72:
                lines.insert(i, lines[rng.randrange(len(lines))])
            elif op < 0.80:  # a key renamed
                ms = list(re.finditer(r'\b(\w+)(\s*:)', lines[i]))
                if ms:
                    m = rng.choice(ms)
                    k = m.group(1)
                    k2 = rng.choice([k[:-1], k + 's', k.upper(), 'type', 'params', 'name']) or 'x'
                    lines[i] = lines[i][:m.start(1)] + k2 + lines[i][m.end(1):]
            elif op < 0.86:  # indentation
                lines[i] = (rng.choice(['  ', '\t', ' ']) + lines[i] if rng.random() < 0.5
                            else lines[i].lstrip())
            elif op < 0.92:  # one plugin type swapped for another of the file
                types = re.findall(r'type:\s*(\w+)', text)
                m = re.search(r'(type:\s*)(\w+)', lines[i])
                if m and types:
                    lines[i] = lines[i][:m.start(2)] + rng.choice(types) + lines[i][m.end(2):]
            elif op < 0.96:
                del lines[i:]
            else:
                return self.flip_bytes('\n'.join(lines).encode(), 4)
            return lines

        return self.edit_lines(text, edit, 'utf-8')

    def flip_bytes(self, b, most):
        b = bytearray(b)
        for _ in range(self.rng.randint(1, most)):
            if b:
                b[self.rng.randrange(len(b))] = self.rng.randrange(256)
        return bytes(b)

    def mutate_log(self, raw):
        """An LCM log damaged as a disk, a killed writer or a bad sender would: bytes flipped
        (in headers, lengths, or messages: a grid's layer count, a string's length), a cut at any
        byte, a stretch removed or repeated, junk between events."""
        rng = self.rng
        op = rng.randrange(5)
        if op == 0:
            return self.flip_bytes(raw, 40)
        if op == 1:
            return raw[:rng.randrange(len(raw) + 1)]
        a = rng.randrange(len(raw) + 1)
        b = min(len(raw), a + rng.choice([1, 4, 28, 100, 4096, 100000]))
        if op == 2:
            return raw[:a] + raw[b:]
        if op == 3:
            return raw[:b] + raw[a:]
        return raw[:a] + bytes(rng.randrange(256) for _ in range(rng.randrange(1, 64))) + raw[a:]

    def mutate_text(self, text):
        rng = self.rng

        def edit(lines, i):
            op = rng.randrange(8)
            toks = lines[i].split(' ')
            if op == 0:
                del lines[i]
            elif op == 1:
                del lines[i:]
            elif op == 2:
                toks[rng.randrange(len(toks))] = rng.choice(
                    ['nan', 'inf', '-inf', '1e308', 'abc', '', '0', '1e-320', '--1', '0x1p3'])
                lines[i] = ' '.join(toks)
            elif op == 3:
                lines[i] = ' '.join(toks[:rng.randrange(len(toks) + 1)])
            elif op == 4:
                lines.insert(i, lines[rng.randrange(len(lines))])
            elif op == 5:
                lines[i] += ' 1 2 3'
            elif op == 6:
                lines[i] = lines[i].replace(':', '', 1)
            else:
                return self.flip_bytes('\n'.join(lines).encode('latin-1'), 5)
            return lines

        return self.edit_lines(text, edit, 'latin-1')

    def mutate_records(self, b, record):
        rng = self.rng
        op = rng.randrange(7)
        if op == 0:
            return b[:rng.randrange(len(b) + 1)]
        if op == 1:
            return b[:rng.randrange(len(b) // record + 1) * record]
        if op == 2:
            return b''
        if op == 3:
            return self.flip_bytes(b, 50)
        if op == 4:  # special floats
            b = bytearray(b)
            for _ in range(rng.randint(1, 2000)):
                i = rng.randrange(len(b) // 4) * 4
                b[i:i + 4] = struct.pack('<f', rng.choice(
                    [float('nan'), float('inf'), -float('inf'), 1e30, -1e30, 0.0, 3e38]))
            return bytes(b)
        if op == 5:
            return b + bytes(rng.randrange(1, 64))
        one = struct.pack('<ffff', *(rng.choice([0.0, 1.0, 1e20]) for _ in range(4)))
        return one * (len(b) // 16)

    def mutate_cloud(self, raw, ply):
        rng = self.rng
        end = raw.find(b'end_header\n') + 11 if ply else raw.find(b'\n', raw.find(b'DATA ')) + 1
        head, body = raw[:end].decode('latin-1'), raw[end:]
        op = rng.randrange(6)
        if op < 3:
            lines = head.split('\n')
            i = rng.randrange(max(1, len(lines) - 1))
            toks = lines[i].split(' ')
            j = rng.randrange(len(toks))
            toks[j] = rng.choice(['0', '-1', '1', '2', '4294967295', '99999999', 'abc', '', 'F',
                                  'U', 'I', 'D', 'binary_compressed', 'ascii', 'double', 'uchar',
                                  'list', 'int', str(rng.randrange(100000)), 'x', 'label', 'ring'])
            if rng.random() < 0.3:
                del toks[j]
            lines[i] = ' '.join(toks)
            if rng.random() < 0.2 and len(lines) > 1:
                del lines[rng.randrange(len(lines) - 1)]
            head = '\n'.join(lines)
        elif op == 3:
            body = body[:rng.randrange(len(body) + 1)]
        elif op == 4:
            body = self.flip_bytes(body, 100)
        else:
            head = head[:rng.randrange(max(1, len(head)))]
        return head.encode('latin-1') + body

    def mutate_file(self, path):
        ext = os.path.splitext(path)[1].lower()
        raw = open(path, 'rb').read()
        if ext in ('.bin', '.label'):
            out = self.mutate_records(raw, 16 if ext == '.bin' else 4)
        elif ext in ('.png', '.jpg'):
            op = self.rng.randrange(3)
            out = (raw[:self.rng.randrange(len(raw))] if op == 0
                   else self.flip_bytes(raw, 30) if op == 1 else b'')
        elif ext in ('.pcd', '.ply'):
            out = self.mutate_cloud(raw, ext == '.ply')
        elif ext == '.lcm':
            out = self.mutate_log(raw)
        elif ext == '.yaml':
            out = self.mutate_yaml(raw.decode('utf-8', 'replace'))
        else:
            out = self.mutate_text(raw.decode('latin-1'))
        open(path, 'wb').write(out)

    # ---- scenarios on input files --------------------------------------------------------------
    def data_path(self, *parts):
        p = os.path.join(self.data, *parts)
        if not os.path.exists(p):
            sys.exit('fuzz_inputs: %s is missing (give the shared data folder with --data)' % p)
        return p

    def classify_config(self, case, source_block):
        """configs/semantickitti.yaml with its source replaced and its files in `case`."""
        shutil.copy(os.path.join(CONFIGS, 'models/laser_semantickitti.yaml'), case + '/model.yaml')
        text = open(os.path.join(CONFIGS, 'semantickitti.yaml')).read()
        text = re.sub(r'source:\n(  .*\n)+', source_block, text)
        text = text.replace('models/laser_semantickitti.yaml', case + '/model.yaml')
        open(case + '/config.yaml', 'w').write(text)

    def scen_kitti(self, case):
        seq = self.data_path('semantickitti_seq00_000000-000005', 'sequences', '00')
        s = case + '/seq/sequences/00'
        os.makedirs(s + '/velodyne')
        os.makedirs(s + '/labels')
        # Frame 000001 stays intact: the run reads frame 000000 on its reader thread, and one bad
        # frame must not cost the next.
        for f in ('000000', '000001'):
            shutil.copy(seq + '/velodyne/%s.bin' % f, s + '/velodyne/')
            shutil.copy(seq + '/labels/%s.label' % f, s + '/labels/')
        shutil.copy(seq + '/calib.txt', s)
        shutil.copy(seq + '/poses.txt', s)
        shutil.copy(os.path.join(CONFIGS, 'label_maps/semantickitti.yaml'), case + '/lm.yaml')
        self.classify_config(case, 'source:\n  type: semantickitti\n  params: {path: %s/seq, '
                             'label_map: %s/lm.yaml, use_poses: true}\n' % (case, case))
        return [s + '/velodyne/000000.bin', s + '/labels/000000.label', s + '/calib.txt',
                s + '/poses.txt', case + '/lm.yaml', case + '/model.yaml']

    def lcm_seed(self):
        """Two scans of configs/lcm_record.yaml as an LCM log (points, labels, poses, samples,
        camera images, grids), recorded once per run."""
        d = os.path.join(self.work, 'lcm_seed')
        log = os.path.join(d, 'seed.lcm')
        if os.path.exists(log):
            return log
        os.makedirs(d, exist_ok=True)
        text = open(os.path.join(CONFIGS, 'lcm_record.yaml')).read()
        text = text.replace('file://out/lcm_demo.lcm', 'file://' + log)
        text = text.replace('models/', os.path.join(CONFIGS, 'models') + '/')
        open(d + '/record.yaml', 'w').write(text)
        rc, out = self.run([self.bin, 'run', d + '/record.yaml', '--limit', '2', '--no-progress',
                            '--out', d + '/out'], d)
        if rc != 0 or not os.path.exists(log):
            sys.exit('fuzz_inputs: recording the LCM seed log failed (%s):\n%s' % (rc, out))
        return log

    def scen_lcm(self, case):
        """The recorded log read by configs/lcm_replay.yaml (every message kind, cameras
        included) or by configs/lcm_classify.yaml (the grids' layers taken as they came)."""
        log = case + '/run.lcm'
        shutil.copy(self.lcm_seed(), log)
        name = self.rng.choice(['lcm_replay.yaml', 'lcm_classify.yaml'])
        text = open(os.path.join(CONFIGS, name)).read()
        text, n = re.subn(r'(\n    path: ).*', r'\g<1>' + log, text)
        assert n == 1, name
        text = text.replace('models/', os.path.join(CONFIGS, 'models') + '/')
        open(case + '/config.yaml', 'w').write(text)
        return [log]

    def mesh_config(self, case, name, path):
        """configs/<name> (a textured-mesh run) reading its source from `path`."""
        text = open(os.path.join(CONFIGS, name)).read()
        text, n = re.subn(r'(\n    path: ).*', r'\g<1>' + path, text)
        assert n == 1, name
        text = text.replace('label_maps/', os.path.join(CONFIGS, 'label_maps') + '/')
        open(case + '/config.yaml', 'w').write(text)

    def scen_rellis(self, case):
        r = case + '/rellis'
        shutil.copytree(self.data_path('rellis3d_example_000104'), r,
                        ignore=shutil.ignore_patterns('PROVENANCE.md', 'vel*'))
        files = [os.path.join(r, f) for f in sorted(os.listdir(r))]
        if self.rng.random() < 0.3:  # the textured mesh reads the image and its calibration too
            self.mesh_config(case, 'mesh_rellis.yaml', r)
            return files  # the mesh reads no label map: mutating one would test nothing
        shutil.copy(os.path.join(CONFIGS, 'label_maps/rellis3d.yaml'), case + '/lm.yaml')
        self.classify_config(case, 'source:\n  type: rellis3d\n  params: {path: %s, label_map: '
                             '%s/lm.yaml, use_images: %s, use_image_labels: true}\n'
                             % (r, case, self.rng.choice(['true', 'false'])))
        return files + [case + '/lm.yaml']

    def scen_kitti_object(self, case):
        """KITTI object frame 000000 (scan, image_2 PNG, calib/*.txt) meshed with its image."""
        src = self.data_path('kitti_object_fusion', 'training')
        t = case + '/training'
        files = []
        for sub in ('velodyne/000000.bin', 'image_2/000000.png', 'calib/000000.txt'):
            os.makedirs(os.path.dirname(os.path.join(t, sub)), exist_ok=True)
            shutil.copy(os.path.join(src, sub), os.path.join(t, sub))
            files.append(os.path.join(t, sub))
        self.mesh_config(case, 'mesh_kitti.yaml', t)
        return files

    def pcd_seeds(self):
        """PCD (binary and ASCII) and PLY files made from seq 00 scan 0, once per run."""
        d = os.path.join(self.work, 'pcd_seeds')
        if os.path.isdir(d):
            return d
        os.makedirs(d)
        seq = self.data_path('semantickitti_seq00_000000-000005', 'sequences', '00')
        b = open(seq + '/velodyne/000000.bin', 'rb').read()
        lab = open(seq + '/labels/000000.label', 'rb').read()
        idx = range(0, len(b) // 16, 4)
        pts = [struct.unpack_from('<ffff', b, 16 * i) for i in idx]
        labels = [struct.unpack_from('<I', lab, 4 * i)[0] & 0xFFFF for i in idx]
        head = ('# .PCD v0.7\nVERSION 0.7\nFIELDS x y z intensity label\nSIZE 4 4 4 4 4\n'
                'TYPE F F F F U\nCOUNT 1 1 1 1 1\nWIDTH {n}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\n'
                'POINTS {n}\nDATA {kind}\n')
        body = b''.join(struct.pack('<ffffI', *p, l) for p, l in zip(pts, labels))
        open(d + '/seed.pcd', 'wb').write(head.format(n=len(pts), kind='binary').encode() + body)
        ascii_body = ''.join('%g %g %g %g %d\n' % (*p, l) for p, l in zip(pts[:5000], labels))
        open(d + '/seed_ascii.pcd', 'w').write(head.format(n=5000, kind='ascii') + ascii_body)
        ply = ('ply\nformat binary_little_endian 1.0\nelement vertex %d\nproperty float x\n'
               'property float y\nproperty float z\nproperty float intensity\n'
               'property uint label\nend_header\n' % len(pts))
        open(d + '/seed.ply', 'wb').write(ply.encode() + body)
        return d

    def scen_pcd(self, case):
        name = self.rng.choice(['seed.pcd', 'seed.ply', 'seed_ascii.pcd'])
        shutil.copy(os.path.join(self.pcd_seeds(), name), case)
        self.classify_config(case, 'source:\n  type: pointcloud_file\n  params: {path: %s/%s, '
                             'label_map: %s, ring_method: elevation, rings: 64, '
                             'ring_z_offset_m: 0}\n'
                             % (case, name, os.path.join(CONFIGS, 'label_maps/semantickitti.yaml')))
        return [os.path.join(case, name)]

    # ---- running -------------------------------------------------------------------------------
    def judge(self, rc, out, named):
        if rc == 'timeout':
            return 'timeout'
        if rc < 0:
            return 'signal %d' % -rc
        if rc > 4:
            return 'exit status %d' % rc
        if 'Sanitizer' in out or 'runtime error' in out:
            return 'sanitizer report'
        if RAW_ERROR.search(out):
            return "a library's own message"
        if rc in (1, 2, 3, 4) and named and not any(n in out for n in named):
            return 'error does not name the file'
        return None

    def run(self, cmd, cwd):
        try:
            p = subprocess.run(cmd, capture_output=True, timeout=self.timeout, cwd=cwd)
            return p.returncode, (p.stdout + p.stderr).decode('utf-8', 'replace')
        except subprocess.TimeoutExpired:
            return 'timeout', ''

    def keep(self, mode, k, why, cmd, rc, out, files):
        self.flagged += 1
        case = os.path.join(self.work, 'cases', '%s_%d_%d' % (mode, self.seed, k))
        shutil.rmtree(case, ignore_errors=True)
        os.makedirs(case)
        for f in files:
            if os.path.isdir(f):
                shutil.copytree(f, os.path.join(case, os.path.basename(f)),
                                ignore=shutil.ignore_patterns('out'))
            elif os.path.exists(f):
                shutil.copy(f, case)
        with open(os.path.join(case, 'report.txt'), 'w') as r:
            r.write('%s\ncommand: %s\nexit status: %s\n\n%s' % (why, ' '.join(cmd), rc, out[-8000:]))
        print('FLAG %s: %s' % (why, case), flush=True)

    def config_case(self, mode, k, control=False):
        """One mutated seed file run as `mode`; with `control`, the seed as shipped, which must
        succeed (exit 0): else every mutant could end in the same clean error (data or a plugin
        missing) and pass without testing anything."""
        configs = self.config_tree()
        seeds = {
            'config-validate': glob.glob(configs + '/*.yaml') + glob.glob(configs + '/train/*.yaml'),
            'config-run': [configs + '/demo.yaml', configs + '/semantickitti.yaml',
                           configs + '/mesh_demo.yaml', configs + '/mesh_kitti.yaml',
                           configs + '/mesh_rellis.yaml', configs + '/lcm_replay.yaml',
                           configs + '/lcm_classify.yaml'],
            'sweep': glob.glob(configs + '/sweeps/*.yaml'),
            'train': glob.glob(configs + '/train/*.yaml'),
            'compare': [configs + '/sweeps/simulator.yaml'],
        }[mode]
        seed_file = self.rng.choice(sorted(seeds))
        # Beside the original (in the copy), so that its relative paths hold.
        path = os.path.join(os.path.dirname(seed_file), '.fuzz_%d_%d.yaml' % (self.seed, k))
        out_dir = os.path.join(self.work, 'out')
        shutil.rmtree(out_dir, ignore_errors=True)
        cmd = {'config-validate': [self.bin, 'validate', path],
               'sweep': [self.bin, 'validate', path],
               'config-run': [self.bin, 'run', path, '--limit', '1', '--no-progress', '--out',
                              out_dir],
               'train': [self.bin, 'train', path, '--limit', '1', '--no-progress', '--out',
                         out_dir + '/model.yaml'],
               'compare': [self.bin, 'compare', path, '--limit', '1', '--no-progress', '--out',
                           out_dir]}[mode]
        try:
            original = open(seed_file, encoding='utf-8').read()
            text = original.encode('utf-8') if control else self.mutate_yaml(original)
            open(path, 'wb').write(text)
            rc, out = self.run(cmd, os.path.dirname(path))
            why = self.judge(rc, out, [])
            if control and not why and rc != 0:
                why = 'control case (%s unmutated) failed with exit status %s' % (
                    os.path.basename(seed_file), rc)
            if (not why and rc == 2 and not re.search(r'\.yaml:\d+', out) and 'usage' not in out
                    and 'the file holds nothing' not in out):
                why = 'config error without a file:line position'
            # Every shipped config opens with a comment: while the mutation left it one, nothing
            # of the user's stands at 1:1, and a message there lost its position (e.g. checked on
            # a copy of the node).
            if (not why and rc == 2 and text.startswith(b'#')
                    and re.search(r'\.yaml:1:1: ', out)):
                why = 'config error at 1:1 (its position was lost)'
            if why:
                self.keep(mode, k, why, cmd, rc, out, [path])
        finally:
            if os.path.exists(path):
                os.remove(path)
        return rc

    def data_case(self, mode, k, control=False):
        """One scenario with one or two of its files mutated; with `control`, none mutated,
        which must succeed (exit 0)."""
        case = os.path.join(self.work, 'case')
        shutil.rmtree(case, ignore_errors=True)
        os.makedirs(case)
        targets = getattr(self, 'scen_' + mode.replace('-', '_'))(case)
        victims = [] if control else self.rng.sample(
            targets, min(len(targets), self.rng.choice([1, 1, 1, 2])))
        for v in victims:
            self.mutate_file(v)
        cmd = [self.bin, 'run', case + '/config.yaml', '--limit', '2', '--no-progress', '--out',
               case + '/out']
        rc, out = self.run(cmd, case)
        why = self.judge(rc, out, [os.path.basename(v) for v in victims])
        if control and not why and rc != 0:
            why = 'control case (%s unmutated) failed with exit status %s' % (mode, rc)
        # Only frame 000000's own files changed: frame 000001 must still be classified.
        if (not why and mode == 'kitti' and rc == 4 and
                all('/000000.' in v for v in victims)):
            why = 'a bad frame cost the intact frame after it'
        if why:
            self.keep(mode, k, why, cmd, rc, out, [case])
        return rc


def main():
    modes = ['config-validate', 'config-run', 'sweep', 'train', 'compare', 'kitti', 'rellis', 'pcd',
             'kitti-object', 'lcm']
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('modes', nargs='+', choices=modes, metavar='MODE',
                    help='what to mutate: ' + ', '.join(modes))
    ap.add_argument('-n', type=int, default=100, help='cases per mode (default 100)')
    ap.add_argument('--seed', type=int, default=1, help='random seed: a run is repeatable')
    ap.add_argument('--bin', default=os.path.join(REPO, 'build/bin/terramrf'))
    ap.add_argument('--data', default=os.path.join(REPO, '..', 'shared', 'data'))
    ap.add_argument('--work', help='folder for cases and outputs (default: a new temp folder)')
    ap.add_argument('--timeout', type=float, default=300, help='seconds per case')
    args = ap.parse_args()
    if not os.access(args.bin, os.X_OK):
        sys.exit('fuzz_inputs: %s is not built (scripts/setup.sh, or --bin)' % args.bin)
    f = Fuzzer(args)
    for mode in args.modes:
        # The control case draws from its own copy of the generator: the mutated cases of a seed
        # stay the ones earlier runs saw.
        state = f.rng.getstate()
        (f.config_case(mode, -1, control=True) if mode in modes[:5]
         else f.data_case(mode, -1, control=True))
        f.rng.setstate(state)
        status = collections.Counter()
        for k in range(args.n):
            rc = (f.config_case(mode, k) if mode in modes[:5] else f.data_case(mode, k))
            status[rc] += 1
        print('%s: %d cases, exit statuses %s' % (mode, args.n, dict(sorted(status.items(),
                                                                       key=str))), flush=True)
    print('%d flagged; cases in %s' % (f.flagged, os.path.join(f.work, 'cases')))
    return 1 if f.flagged else 0


if __name__ == '__main__':
    sys.exit(main())
