import numpy as np, pyuff, os, sys
out = sys.argv[1]
fs = 2048.0
n = 300
t = np.arange(n) / fs
def sig(k):
    # deterministic test signals (also computed in the Rust test)
    return np.sin(2*np.pi*(5.0*(k+1))*t + 0.25*k) * np.exp(-3.0*t) * (10.0**(k-1))
chans = [
    dict(id1='Hammer floor 3', node=3, dir=1, unit='N', k=0),
    dict(id1='Floor 1 acc', node=1, dir=1, unit='m/s^2', k=1),
    dict(id1='Floor 2 acc', node=2, dir=-1, unit='m/s^2', k=2),
]
def write(fname, binary, spacing=1):
    path = os.path.join(out, fname)
    if os.path.exists(path): os.remove(path)
    u = pyuff.UFF(path)
    sets = []
    for c in chans:
        d = pyuff.prepare_58(binary=binary, id1=c['id1'], func_type=1, rsp_node=c['node'], rsp_dir=c['dir'],
            ref_node=3, ref_dir=1, abscissa_spacing=spacing, abscissa_spec_data_type=17,
            abscissa_axis_units_lab='s', ordinate_axis_units_lab=c['unit'], orddenom_spec_data_type=0, ordinate_spec_data_type=(13 if c['k']==0 else 12), z_axis_spec_data_type=0, data=sig(c['k']), x=t)
        sets.append(d)
    open(path,'w').close()
    u = pyuff.UFF(path)
    u.write_sets(sets, mode='add')
write('pyuff_ascii_even.uff', 0)
write('pyuff_binary_even.uff', 1)
write('pyuff_ascii_uneven.uff', 0, spacing=0)
write('pyuff_binary_uneven.uff', 1, spacing=0)
