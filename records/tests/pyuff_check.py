"""Cross-check of frameid's FRF and mode files with pyuff, an independent
UFF reader and writer (run by .ci/python/run.sh):

    cargo run -p records --example pyuff_check -- write DIR
    python records/tests/pyuff_check.py DIR
    cargo run -p records --example pyuff_check -- read DIR

(a) pyuff reads the UFF58 files (ASCII and binary) and the UFF55 file that
    frameid wrote and compares function types, nodes, directions, grids and
    values with DIR/expected.json;
(b) pyuff writes UFF58 function-type-4 FRFs (and a coherence) in ASCII and
    binary, even and uneven spacing, with their values in
    DIR/pyuff_expected.json, which the example's `read` step checks.

Exit status 1 on any mismatch.
"""
import json
import os
import sys

import numpy as np
import pyuff

failures = []


def check(cond, what):
    if not cond:
        failures.append(what)


def close(a, b, rel, floor=0.0):
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and bool(np.all(np.abs(a - b) <= rel * np.maximum(np.abs(b), floor)))


def read_ours(d):
    expected = json.load(open(os.path.join(d, 'expected.json')))
    for name, sets in expected['frf'].items():
        binary = 'binary' in name
        got = [s for s in pyuff.UFF(os.path.join(d, name)).read_sets() if s.get('type') == 58]
        check(len(got) == len(sets), f'{name}: {len(got)} datasets, expected {len(sets)}')
        for k, (g, e) in enumerate(zip(got, sets)):
            tag = f'{name} dataset {k + 1}'
            for key in ('func_type', 'rsp_node', 'rsp_dir', 'ref_node', 'ref_dir'):
                check(int(g[key]) == e[key], f'{tag}: {key} {g[key]} != {e[key]}')
            # pyuff rebuilds an even grid from record 7 (E13.5, 6 digits):
            # 5e-6 relative; stored (uneven, binary) abscissae are exact.
            check(close(g['x'], e['freq'], 1e-5), f'{tag}: frequencies differ')
            want = np.asarray(e['re']) + 1j * np.asarray(e['im'])
            data = np.asarray(g['data'])
            if e['func_type'] == 6:
                data = data.astype(complex)
            # Binary: doubles, exact. ASCII: E20.12, 13 significant digits
            # (5e-13 of each part): 1e-12 of the magnitude.
            rel = 0.0 if binary else 1e-12
            check(close(data, want, rel, 1e-300), f'{tag}: values differ (max {np.max(np.abs(data - want))})')
            if e['func_type'] == 4:
                check(g['ordinate_spec_data_type'] == 12 and g['orddenom_spec_data_type'] == 13,
                      f'{tag}: records 9/10 data types {g["ordinate_spec_data_type"]}/{g["orddenom_spec_data_type"]}')
                check(g['ordinate_axis_units_lab'].strip() == 'm/s^2' and g['orddenom_axis_units_lab'].strip() == 'N',
                      f'{tag}: unit labels')
        print(f'pyuff read {name}: {len(got)} datasets')
    for name, modes in expected['modes'].items():
        got = [s for s in pyuff.UFF(os.path.join(d, name)).read_sets() if s.get('type') == 55]
        check(len(got) == len(modes), f'{name}: {len(got)} modes, expected {len(modes)}')
        for k, (g, e) in enumerate(zip(got, modes)):
            tag = f'{name} mode {k + 1}'
            check(g['analysis_type'] == 3, f'{tag}: analysis type {g["analysis_type"]}')
            check(list(g['node_nums']) == e['nodes'], f'{tag}: nodes {list(g["node_nums"])}')
            # E13.5: 6 significant digits, 5e-6 relative; 1e-5.
            check(close(g['eig'], complex(*e['eig']), 1e-5), f'{tag}: eigenvalue {g["eig"]}')
            check(close(g['modal_a'], complex(*e['modal_a']), 1e-5, 1e-300), f'{tag}: modal A {g["modal_a"]}')
            want = np.array([complex(*z) for z in e['r1']])
            check(close(g['r1'], want, 1e-5, 1.0), f'{tag}: X components {g["r1"]}')
        print(f'pyuff read {name}: {len(got)} modes')


def write_pyuff(d):
    m, k, c = 3.0, 9e3, 5.0

    def accelerance(f, scale):
        w = 2 * np.pi * f
        return scale * (-(w ** 2)) / (k - w * w * m + 1j * w * c)

    out = {}
    for binary in (0, 1):
        for spacing in (1, 0):
            name = f'pyuff_{"binary" if binary else "ascii"}_{"even" if spacing else "uneven"}.uff'
            path = os.path.join(d, name)
            if spacing:
                f = 0.5 + 0.25 * np.arange(48)
            else:
                f = 1.0 + np.arange(30) ** 1.25
            sets, listed = [], []
            for rsp, scale in ((1, 1.0), (3, -0.4)):
                h = accelerance(f, scale)
                sets.append(pyuff.prepare_58(
                    binary=binary, id1=f'H {rsp}:+X/2:+X', func_type=4, rsp_node=rsp, rsp_dir=1,
                    ref_node=2, ref_dir=1, abscissa_spacing=spacing, abscissa_spec_data_type=18,
                    abscissa_axis_units_lab='Hz', ordinate_spec_data_type=12,
                    ordinate_axis_units_lab='m/s^2', orddenom_spec_data_type=13,
                    orddenom_axis_units_lab='N', data=h, x=f))
                entry = {'func_type': 4, 'rsp_node': rsp, 'rsp_dir': 1, 'ref_node': 2, 'ref_dir': 1,
                         'freq': f.tolist(), 're': h.real.tolist(), 'im': h.imag.tolist()}
                if rsp == 1:
                    coh = 0.5 + 0.5 / (1.0 + f)
                    sets.append(pyuff.prepare_58(
                        binary=binary, id1='coherence', func_type=6, rsp_node=rsp, rsp_dir=1,
                        ref_node=2, ref_dir=1, abscissa_spacing=spacing, abscissa_spec_data_type=18,
                        abscissa_axis_units_lab='Hz', ordinate_spec_data_type=0,
                        orddenom_spec_data_type=0, data=coh, x=f))
                    entry['coherence'] = coh.tolist()
                listed.append(entry)
            # An empty file and mode 'add': pyuff's 'overwrite' truncates
            # the header of a binary dataset when it writes the data.
            open(path, 'w').close()
            pyuff.UFF(path).write_sets(sets, mode='add')
            out[name] = {'binary': bool(binary), 'sets': listed}
    json.dump(out, open(os.path.join(d, 'pyuff_expected.json'), 'w'))
    print(f'pyuff wrote {", ".join(out)}')


if __name__ == '__main__':
    d = sys.argv[1]
    read_ours(d)
    write_pyuff(d)
    if failures:
        print('\n'.join(failures), file=sys.stderr)
        sys.exit(1)
