#!/usr/bin/env python3
"""Shadow cost of methods side by side, one scene at a time (the report's shadow_prepare +
render, less `--shadows none`'s), with `analytic`'s counters per scene.

    scripts/method-cost.py SCENES METHODS [REPEATS] [render flags...]
    scripts/method-cost.py scenes/gltf/fox.toml,scenes/gltf/toy-car.toml traced,silhouette,analytic 1 --width 320 --height 240

A method is NAME or NAME:SAMPLES (default 1024); ratios are to the first method."""

import json, os, statistics, subprocess, sys, tempfile
bin='target/release/penumbra'
WORK=tempfile.mkdtemp(prefix='method-cost-')
scenes=sys.argv[1].split(',')
methods=sys.argv[2].split(',')
reps=int(sys.argv[3]) if len(sys.argv)>3 else 1
extra=sys.argv[4:] 
def run(scene, m):
    spec=m.split(':'); name=spec[0]; n=spec[1] if len(spec)>1 else '1024'
    out=os.path.join(WORK, f'{os.path.basename(scene)[:-5]}-{name}-{n}.png')
    subprocess.run([bin,'render',scene,'--quiet','--shadows',name,'--samples',n,'--out',out]+extra,check=True,stderr=subprocess.DEVNULL)
    r=json.load(open(out[:-4]+'.json'))
    t=r['timings_s']; return t['shadow_prepare']+t['render'], r['counters']
for sc in scenes:
    res={}
    for rep in range(reps):
        for m in ['none']+methods:
            c,cnt=run(sc,m); res.setdefault(m,[]).append(c); res[m+'#']=cnt
    none=statistics.median(res['none'])
    line=f"{os.path.basename(sc)[:-5]:22s} none {none:6.2f}"
    base=None
    for m in methods:
        c=statistics.median(res[m])-none
        if base is None: base=c
        line+=f" | {m} {c:7.2f}s x{c/base:5.2f}"
    print(line, flush=True)
    a=res.get('analytic#') or res.get('analytic:1024#')
    if a:
        keys=['analytic_points','points_exact','points_umbra','edges_active','crossings','pieces','near_light_outlines','segments_merged']+[k for k in a if k.startswith('points_counted_')]
        ex=max(a['points_exact'],1)
        print('   ', {k:a.get(k) for k in keys}, f"edges/exact {a['edges_active']/ex:.1f} cross/edge {a['crossings']/max(a['edges_active'],1):.2f}", flush=True)
