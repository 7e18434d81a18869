#!/usr/bin/env python3
"""Lists the lines an lcov trace says no test ran, by file, and the uncovered lines that raise or
report an error (throw, d.add, ...Error, "expected") on their own: bad-input paths without a test.

usage: uncovered.py TRACE.info --root SOURCE_DIR --out DIR
"""
import argparse
import os
import re

ERROR_LINE = re.compile(r'\bthrow\b|\bd\.add\(|Error\(|issues\.push_back|expected|std::cerr')


def read_trace(path):
    files, current = {}, None
    with open(path) as f:
        for line in f:
            line = line.strip()
            if line.startswith('SF:'):
                current = files.setdefault(line[3:], {})
            elif line.startswith('DA:') and current is not None:
                number, count = line[3:].split(',')[:2]
                current[int(number)] = current.get(int(number), 0) + int(count)
    return files


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('trace')
    ap.add_argument('--root', required=True)
    ap.add_argument('--out', required=True)
    a = ap.parse_args()
    files = read_trace(a.trace)
    rows, errors = [], []
    for path in sorted(files):
        missed = sorted(n for n, c in files[path].items() if c == 0)
        if not missed:
            continue
        rel = os.path.relpath(path, a.root)
        with open(path, errors='replace') as f:
            text = f.read().split('\n')
        rows.append(f'=== {rel} ({len(missed)} of {len(files[path])} lines not run)')
        for n in missed:
            src = text[n - 1] if n - 1 < len(text) else ''
            rows.append(f'{n:5d}: {src}')
            if ERROR_LINE.search(src):
                errors.append(f'{rel}:{n}: {src.strip()}')
    with open(os.path.join(a.out, 'uncovered.txt'), 'w') as f:
        f.write('\n'.join(rows) + '\n')
    with open(os.path.join(a.out, 'uncovered_errors.txt'), 'w') as f:
        f.write('\n'.join(errors) + '\n')
    print(f'{len(errors)} uncovered error lines: {os.path.join(a.out, "uncovered_errors.txt")}')
    print(f'every uncovered line: {os.path.join(a.out, "uncovered.txt")}')


if __name__ == '__main__':
    main()
