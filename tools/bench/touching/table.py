"""The cue-separation table of docs/benchmarks/15-touching-objects.md from rec/ (GT-depth cues) and recg42/ (the gate as built)."""
import glob
import json
import numpy as np


def kind_of(r, objs, gap):
    ga, gb = r['ga'], r['gb']
    if ga == gb:
        if ga <= 3:
            return 'room'
        return 'patterned' if objs[ga]['texture'] != 'plain' else 'plain'
    contact = gap is not None and gap < 0.03
    if ga <= 3 and gb <= 3:
        k = 'room-room'
    elif ga <= 3 or gb <= 3:
        k = 'obj-room'
    else:
        both = set(objs[ga]['classes']) & set(objs[gb]['classes'])
        if 'same_depth_pair' in both:
            k = 'obj-obj same_depth'
        elif 'white_pair' in both:
            k = 'obj-obj white'
        elif ('touching' in both or 'stacked' in both) and contact:
            k = 'obj-obj touching/stacked'
        else:
            k = 'obj-obj other'
    return k + (' contact' if contact else ' occl')


rows = []
for f in sorted(glob.glob('rec/*.json')):
    name = f.split('/')[-1]
    d = json.load(open(f))
    objs = {int(k): v for k, v in d['objects'].items()}
    try:
        g = json.load(open(f'recg42/{name}'))
        gmap = {(r['view'], r['a'], r['b']): r for r in g['records']}
    except FileNotFoundError:
        gmap = None
    for r in d['records']:
        if r['ga'] == 0 or r['gb'] == 0:
            continue
        r['wrong'] = r['ga'] != r['gb']
        r['w'] = min(r['area_a'], r['area_b'])
        r['kind'] = kind_of(r, objs, r['gt_rel_gap'])
        r['dcol'] = float(np.abs(np.array(r['colour_a']) - np.array(r['colour_b'])).max())
        xv = [p for p in r['xview'] if p[3] is not None]
        r['n_both'] = len(xv)
        r['n_cov'] = sum(p[3] >= 0.5 for p in xv)
        xb = [p for p in r['xband'] if not p[8]]
        r['b_both'] = len(xb)
        r['b_tog'] = sum(p[3] >= 0.5 for p in xb)
        r['b_apart'] = sum(p[3] < 0.5 and (p[6] >= 2 or p[7] >= 2) for p in xb)
        c9, c5 = r['concav']['9'], r['concav']['5']
        r['conc9'] = max(c9) if c9 else None
        r['conc5'] = max(c5) if c5 else None
        r['g'] = None
        if gmap is not None:
            gr = gmap.get((r['view'], r['a'], r['b']))
            if gr is not None:
                t = x = 0
                for na, nb, tog, wa, wb in gr['ev']:
                    if na < 3 or nb < 3:
                        continue
                    if tog:
                        t += 1
                    elif wa >= 2 or wb >= 2:
                        x += 1
                r['g'] = (t, x, sum(1 for e in gr['ev'] if e[0] >= 3 and e[1] >= 3))
        rows.append(r)

have_g = all(r['g'] is not None for r in rows)
print(f'{len(glob.glob("rec/*.json"))} scenes, {len(rows)} executed merges, '
      f'{sum(r["wrong"] for r in rows)} join two objects; gate data for all: {have_g}\n')


def cell(g, block):
    b = [r for r in g if block(r)]
    tot = sum(r['w'] for r in g)
    return f'{len(b)} / {len(g)} ({100 * sum(r["w"] for r in b) / max(tot, 1):.1f} %)'


groups = {
    'target': [r for r in rows if r['wrong'] and r['kind'].startswith('obj-obj') and r['kind'].endswith('contact')],
    'wrong': [r for r in rows if r['wrong']],
    'right': [r for r in rows if not r['wrong']],
    'pat': [r for r in rows if not r['wrong'] and r['kind'] == 'patterned'],
    'patc': [r for r in rows if not r['wrong'] and r['kind'] == 'patterned' and r['dcol'] > 40],
    'plain': [r for r in rows if not r['wrong'] and r['kind'] == 'plain'],
    'room': [r for r in rows if not r['wrong'] and r['kind'] == 'room'],
}
print('| cue: refuse the merge when | wrong: two objects at a contact | wrong: all | correct: all | correct: '
      'patterned objects | of which across a colour edge | correct: plain objects | correct: floor, walls |')
print('| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |')


def line(name, block):
    print(f'| {name} | ' + ' | '.join(cell(groups[k], block) for k in
                                     ('target', 'wrong', 'right', 'pat', 'patc', 'plain', 'room')) + ' |')


line('(a) minima rule: union concave at a junction, disc r = 9 px > 0.65', lambda r: r['conc9'] is not None and r['conc9'] > 0.65)
line('(a) minima rule: disc r = 9 px > 0.75', lambda r: r['conc9'] is not None and r['conc9'] > 0.75)
line('(a) minima rule: disc r = 5 px > 0.75', lambda r: r['conc5'] is not None and r['conc5'] > 0.75)
line('(b1) this view: no SAM mask holds half of each region', lambda r: r['inview_cov'] < 0.5)
line('(b2) other views, whole regions: one mask holds both in < 20 % of ≥ 3 views', lambda r: r['n_both'] >= 3 and r['n_cov'] < 0.2 * r['n_both'])
line('(b3) other views, 2–4 px from the contact: one mask holds both in < 20 % of ≥ 3 views', lambda r: r['b_both'] >= 3 and r['b_tog'] < 0.2 * r['b_both'])
line('(b4) other views, 2–4 px from the contact: apart in a whole in ≥ 2 views, together in fewer', lambda r: r['b_apart'] >= 2 and r['b_tog'] < r['b_apart'])
if have_g:
    line('**(b5) the gate as built**: (b4) through the Gaussians, rendered depth, a quarter of the views', lambda r: r['g'][1] >= max(2, 0.25 * r['g'][2]) and r['g'][0] < r['g'][1])
line('(b4) and (a) r = 9 px > 0.65', lambda r: r['b_apart'] >= 2 and r['b_tog'] < r['b_apart'] and r['conc9'] is not None and r['conc9'] > 0.65)
line('(c) descriptor cosine < 0.9', lambda r: r['terms']['cos'] < 0.9)
line('(c) descriptor cosine < 0.95', lambda r: r['terms']['cos'] < 0.95)
line('(c) score S < 0.9 (τ_merge 0.85 → 0.9)', lambda r: r['terms']['score'] < 0.9)
line('(c) crease: concave by more than 20°', lambda r: r['terms'].get('crease_deg') is not None and r['terms']['crease_deg'] < -20)

print('\nWrong merges by kind, and what the gate as built (b5) refuses:\n')
print('| kind | merges | px (smaller side) | refused by (b4) | refused by (b5) |')
print('| --- | ---: | ---: | ---: | ---: |')
kinds = {}
for r in rows:
    kinds.setdefault(('wrong ' if r['wrong'] else 'correct ') + r['kind'], []).append(r)
for k in sorted(kinds):
    g = kinds[k]
    b4 = cell(g, lambda r: r['b_apart'] >= 2 and r['b_tog'] < r['b_apart'])
    b5 = cell(g, lambda r: r['g'] is not None and r['g'][1] >= max(2, 0.25 * r['g'][2]) and r['g'][0] < r['g'][1]) if have_g else '–'
    print(f'| {k} | {len(g)} | {sum(r["w"] for r in g)} | {b4} | {b5} |')
