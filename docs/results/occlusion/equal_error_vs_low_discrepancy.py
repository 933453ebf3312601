# Equal-error ratios of aaf_ao (at mu = 2) against mc_ao_low_discrepancy, read from
# docs/results/<scene>/ambient_occlusion/tradeoff.json (log-log interpolation on the low-discrepancy curve).
# Run from the repository root: python3 docs/results/occlusion/equal_error_vs_low_discrepancy.py boxes,bunny,...
import json, math, sys
scenes=sys.argv[1].split(',')
def interp(points, rmse, key):
    # points sorted by rays; log-log interpolation of key at rmse
    pts=sorted(points,key=lambda p:p['rays_per_pixel'])
    for a,b in zip(pts,pts[1:]):
        if (a['rmse']-rmse)*(b['rmse']-rmse)<=0 and a['rmse']!=b['rmse']:
            t=(math.log(rmse)-math.log(a['rmse']))/(math.log(b['rmse'])-math.log(a['rmse']))
            return math.exp(math.log(a[key])+t*(math.log(b[key])-math.log(a[key])))
    return None
print("| scene | aaf_ao μ | rays/px | RMSE | LD MC rays/px | rays ratio vs LD | time ratio vs LD |")
print("|---|---:|---:|---:|---:|---:|---:|")
for sc in scenes:
    d=json.load(open(f'docs/results/{sc}/ambient_occlusion/tradeoff.json'))
    M={m['name']:m for m in d['methods']}
    ld=M['mc_ao_low_discrepancy']['points']
    for p in M['aaf_ao']['points']:
        if p['knob_value']!=2.0: continue
        r=interp(ld,p['rmse'],'rays_per_pixel'); t=interp(ld,p['rmse'],'time_ms')
        rs = f"{r:.1f}" if r else "beyond sweep"
        print(f"| {sc} | {p['knob_value']:g} | {p['rays_per_pixel']:.1f} | {p['rmse']:.4f} | {rs} | {r/p['rays_per_pixel']:.2f}x | {t/p['time_ms']:.2f}x |" if r else f"| {sc} | 2 | {p['rays_per_pixel']:.1f} | {p['rmse']:.4f} | > 256 spp sweep | > {256/p['rays_per_pixel']:.2f}x | — |")
