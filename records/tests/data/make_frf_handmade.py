# Hand-made dataset-58 FRF vector (function types 4 and 6), each record
# composed field by field from the published layout. Independent of
# frameid's writer. The values are a single-DOF receptance in closed form,
# H(f) = 1 / (k - w^2 m + i w c), printed in the file's units; the Rust test
# (records/tests/frf_uff58.rs) recomputes it in SI.
#
#   python3 make_frf_handmade.py .
import cmath, math, os, sys

out = sys.argv[1]
M, K, C = 2.0, 8000.0, 4.0          # kg, N/m, N s/m
G = 9.80665                         # m/s^2 per g
LBF = 4.4482216152605               # N per lbf
F = [5.0, 10.0, 15.0, 20.0]         # Hz

def I(v, w): s = str(v); assert len(s) <= w; return s.rjust(w)
def A(s, w): assert len(s) <= w; return s.ljust(w)
def E(v, w, d):
    s = ('%.' + str(d) + 'E') % v
    assert len(s) <= w, s
    return s.rjust(w)
def rec6(ftype, fid, rname, rnode, rdir, fname, fnode, fdir):
    return I(ftype,5)+I(fid,10)+I(0,5)+I(0,10)+' '+A(rname,10)+I(rnode,10)+I(rdir,4)+' '+A(fname,10)+I(fnode,10)+I(fdir,4)
def rec7(ot, n, sp, xmin, dx):
    return I(ot,10)+I(n,10)+I(sp,10)+E(xmin,13,5)+E(dx,13,5)+E(0.0,13,5)
def axis(t, le, fe, te, lab, unit):
    return I(t,10)+I(le,5)+I(fe,5)+I(te,5)+' '+A(lab,20)+' '+A(unit,20)
def ids(id1):
    return [A(id1, 80), A('NONE', 80), A('NONE', 80), A('NONE', 80), A('NONE', 80)]
def receptance(f):
    w = 2 * math.pi * f
    return 1 / complex(K - w * w * M, w * C)

lines = []
# Dataset 151 (model header): skipped by the reader.
lines += ['    -1', '   151', A('handmade FRF', 80), A('NONE', 80), A('NONE', 80), '    -1']
# Dataset 58, FRF: driving point 1:+X, receptance in mm/N, complex single,
# even spacing, 6E13.5 (three complex values per line).
vals = []
for f in F:
    h = receptance(f) * 1000.0
    vals += [h.real, h.imag]
lines += ['    -1', '    58'] + ids('H 1:+X/1:+X receptance')
lines += [rec6(4, 1, 'NONE', 1, 1, 'NONE', 1, 1), rec7(5, 4, 1, 5.0, 5.0),
          axis(18, 0, 0, 0, 'Frequency', 'Hz'), axis(8, 1, 0, 0, 'Displacement', 'mm'),
          axis(13, 0, 1, 0, 'Force', 'N'), axis(0, 0, 0, 0, 'NONE', 'NONE')]
for i in range(0, len(vals), 6):
    lines.append(''.join(E(v, 13, 5) for v in vals[i:i + 6]))
lines.append('    -1')
# Dataset 58, coherence of the same pair: real single, even.
coh = [0.9, 0.95, 0.99, 1.0]
lines += ['    -1', '    58'] + ids('coherence 1:+X/1:+X')
lines += [rec6(6, 2, 'NONE', 1, 1, 'NONE', 1, 1), rec7(2, 4, 1, 5.0, 5.0),
          axis(18, 0, 0, 0, 'Frequency', 'Hz'), axis(0, 0, 0, 0, 'Coherence', 'NONE'),
          axis(0, 0, 0, 0, 'NONE', 'NONE'), axis(0, 0, 0, 0, 'NONE', 'NONE')]
lines.append(''.join(E(v, 13, 5) for v in coh))
lines.append('    -1')
# Dataset 58, FRF: response 2:+X (entity ACC2) over 1:+X, accelerance
# 0.5 * (i w)^2 H in g/lbf, complex double, uneven spacing, E13.5,2E20.12.
lines += ['    -1', '    58'] + ids('H ACC2/1:+X accelerance')
lines += [rec6(4, 3, 'ACC2', 2, 1, 'NONE', 1, 1), rec7(6, 4, 0, 0.0, 0.0),
          axis(18, 0, 0, 0, 'Frequency', 'Hz'), axis(12, 0, 0, 0, 'Acceleration', 'g'),
          axis(13, 0, 0, 0, 'Force', 'lbf'), axis(0, 0, 0, 0, 'NONE', 'NONE')]
for f in F:
    w = 2 * math.pi * f
    a = 0.5 * (1j * w) ** 2 * receptance(f) * LBF / G
    lines.append(E(f, 13, 5) + E(a.real, 20, 12) + E(a.imag, 20, 12))
lines.append('    -1')
with open(os.path.join(out, 'handmade_frf.uff'), 'w', newline='\n') as fh:
    fh.write('\n'.join(lines) + '\n')
