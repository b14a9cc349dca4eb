# Hand-made dataset-58 vectors, each record composed field by field from the
# published layout. Independent of frameid's writer.
import sys, os
out = sys.argv[1]
def I(v, w): s = str(v); assert len(s) <= w; return s.rjust(w)
def A(s, w): assert len(s) <= w; return s.ljust(w)
def E_1p(v, w, d):
    # 1PEw.d: d.ddddE+xx
    s = ('%.' + str(d) + 'E') % v
    assert len(s) <= w, s
    return s.rjust(w)
def E_f(v, w, d):
    # Fortran default Ew.d: 0.ddddE+xx (mantissa in [0.1, 1))
    if v == 0: s = '0.' + '0'*d + 'E+00'
    else:
        import math
        e = math.floor(math.log10(abs(v))) + 1
        m = abs(v) / 10**e
        s = ('%.' + str(d) + 'f') % m
        if s.startswith('1.'):  # rounding overflow
            e += 1; s = ('%.' + str(d) + 'f') % (abs(v)/10**e)
        s = ('-' if v < 0 else '') + s + 'E' + ('-' if e < 0 else '+') + ('%02d' % abs(e))
    assert len(s) <= w, s
    return s.rjust(w)
def rec6(ftype, fid, ver, lc, rname, rnode, rdir, fname, fnode, fdir):
    return I(ftype,5)+I(fid,10)+I(ver,5)+I(lc,10)+' '+A(rname,10)+I(rnode,10)+I(rdir,4)+' '+A(fname,10)+I(fnode,10)+I(fdir,4)
def rec7(ot, n, sp, xmin, dx, z):
    return I(ot,10)+I(n,10)+I(sp,10)+E_1p(xmin,13,5)+E_1p(dx,13,5)+E_1p(z,13,5)
def axis(t, le, fe, te, lab, unit):
    return I(t,10)+I(le,5)+I(fe,5)+I(te,5)+' '+A(lab,20)+' '+A(unit,20)
def data(vals, per, fmt):
    lines = []
    for i in range(0, len(vals), per):
        lines.append(''.join(fmt(v) for v in vals[i:i+per]))
    return lines

# ---- vector 1: real single, even, 6E13.5, negative abscissa minimum,
#      with datasets 151 and 164 before and between.
L = []
L += ['    -1', '   151', 'frame_model', 'three storey shear frame, hammer test', 'handmade',
      A('23-Mar-24',10)+A('10:15:00',10)+I(1,10)+I(0,10)+I(0,10),
      A('23-Mar-24',10)+A('10:15:00',10), 'handmade', A('23-Mar-24',10)+A('10:15:00',10)+I(1,5)+I(0,5)+I(0,5)+I(0,5)+I(0,5), '    -1']
L += ['    -1', '   164', I(1,10)+A('SI - mks (Newton)',20)+I(2,10),
      '  1.00000000000000000D+00  1.00000000000000000D+00  1.00000000000000000D+00',
      '  2.73150000000000000D+02', '    -1']
force = [0.0, 1.25, 12.5, 48.75, 31.25, 6.0, -0.5, 0.0625, 0.0, -0.003125]
acc = [0.0, 0.001, -0.0234, 0.5, 1.75, -2.125, 0.875, -0.0625, 0.0156, -0.0039]
L += ['    -1', '    58', 'Hammer force floor 3', 'NONE', '23-Mar-24  10:15:00', 'NONE', 'NONE',
      rec6(1, 1, 1, 0, 'NONE', 3, 1, 'NONE', 3, 1),
      rec7(2, 10, 1, -0.01, 0.0025, 0.0),
      axis(17, 0, 0, 0, 'Time', 's'),
      axis(13, 0, 1, 0, 'Force', 'N'),
      axis(0, 0, 0, 0, 'NONE', 'NONE'),
      axis(0, 0, 0, 0, 'NONE', 'NONE')]
L += data(force, 6, lambda v: E_1p(v, 13, 5))
L += ['    -1']
L += ['    -1', '    58', 'Accelerometer floor 2', 'NONE', '23-Mar-24  10:15:00', 'NONE', 'NONE',
      rec6(1, 2, 1, 0, 'FLOOR 2', 2, -1, 'FLOOR 3', 3, 1),
      rec7(2, 10, 1, -0.01, 0.0025, 0.0),
      axis(17, 0, 0, 0, 'Time', 's'),
      axis(12, 1, 0, 0, 'Acceleration', 'm/s^2'),
      axis(0, 0, 0, 0, 'NONE', 'NONE'),
      axis(0, 0, 0, 0, 'NONE', 'NONE')]
L += data(acc, 6, lambda v: E_f(v, 13, 5))
L += ['    -1']
open(os.path.join(out, 'handmade_single_even.uff'), 'w', newline='\n').write('\n'.join(L) + '\n')

# ---- vector 2: real double, uneven, 2(E13.5,E20.12), CRLF line ends,
#      blank ID line 1 (name from node/direction), abscissa in ms.
xs = [500.0 + 0.25*i for i in range(7)]         # ms
ys = [1.234567890123, -9.87654321e-05, 3.0e-300, 0.0, -1.0e100, 2.5, 7.000000000001e-3]
L = ['    -1', '    58', '', 'NONE', 'NONE', 'NONE', 'NONE',
     rec6(1, 0, 0, 0, 'NONE', 101, 3, 'NONE', 0, 0),
     rec7(4, 7, 0, 0.0, 0.0, 0.0),
     axis(17, 0, 0, 0, 'Time', 'ms'),
     axis(12, 1, 0, 0, 'Acceleration', 'g'),
     axis(0, 0, 0, 0, 'NONE', 'NONE'),
     axis(0, 0, 0, 0, 'NONE', 'NONE')]
pairs = []
for x, y in zip(xs, ys): pairs += [x, y]
fmt = [lambda v: E_1p(v, 13, 5), lambda v: E_1p(v, 20, 12)]
row = []
for i, v in enumerate(pairs):
    row.append(fmt[i % 2](v))
    if len(row) == 4: L.append(''.join(row)); row = []
if row: L.append(''.join(row))
L += ['    -1']
open(os.path.join(out, 'handmade_double_uneven_crlf.uff'), 'w', newline='').write('\r\n'.join(L) + '\r\n')
