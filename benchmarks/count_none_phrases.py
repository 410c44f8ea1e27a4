import numpy as np, sys, time
from dataclasses import replace
from siftom.assist.questions import count_question
from siftom.bench import trials
from siftom.bench.answers import answer_audio
from siftom.bench.llm_baselines import command_space
from siftom.bench.stimuli import load_dataset, scenario_for
from siftom.world.commands import RobotCommand
ds=load_dataset('/work/final/dev1/household/dataset')
st=list(ds.stimuli); rng=np.random.default_rng(0); idx=sorted(rng.choice(len(st),int(sys.argv[1]),replace=False))
VARIANTS={
 'current':(("no {p}","no thanks","none of them"),("no","none")),
 'nothing':(("nothing","nothing thanks","I don't need any"),("nothing","don't","any")),
 'dontneed':(("I don't need {p}","I don't need any","not any {p}"),("don't","any","not")),
 'zero':(("zero","zero {p}","I don't need any"),("zero","don't","any")),
}
def listen(x,g): return trials._engine('pocketsphinx-vocab',g).transcribe(x,nbest=5)
res={v:{} for v in VARIANTS}; numres={v:{} for v in VARIANTS}
t=time.time()
for i in idx:
    s=st[i]; sc=scenario_for(s); cmds=[str(c) for c in command_space(sc)]
    gold=RobotCommand.parse(s.gold_command).obj_class
    others=sorted({RobotCommand.parse(c).obj_class for c in cmds}-{gold}-set(c for c,_ in sc.goal.counts))
    if not others: continue
    cls=others[int(np.random.default_rng(i).integers(len(others)))]
    q0=count_question(cls,cmds); plural=q0.text[len('How many '):-1]
    snr=float('inf') if s.snr_db is None else s.snr_db
    for v,(phr,keys) in VARIANTS.items():
        cells=q0.answers[:-1]+(tuple(p.format(p=plural) for p in phr),)
        q=replace(q0,answers=cells,keys=q0.keys[:-1]+(keys,))
        for k,ph in enumerate(q.answers[-1]):
            tr=listen(answer_audio(s,ph,str(ds.root),salt=k),q.grammar())
            hc=None
            for h in [x.text for x in tr.nbest] or [tr.text]:
                hc=q.heard_cell(h)
                if hc is not None: break
            res[v].setdefault(snr,[]).append(hc==q.n_cells-1)
        # a number answer through the same grammar
        ph=q.answers[0][0]; tr=listen(answer_audio(s,ph,str(ds.root),salt=9),q.grammar())
        hc=None
        for h in [x.text for x in tr.nbest] or [tr.text]:
            hc=q.heard_cell(h)
            if hc is not None: break
        numres[v].setdefault(snr,[]).append(hc==0)
print('%.0fs'%(time.time()-t))
for v in VARIANTS:
    print(v,'none-cell',' '.join('%s %.2f(n%d)'%(k,np.mean(x),len(x)) for k,x in sorted(res[v].items())),'| number',' '.join('%s %.2f'%(k,np.mean(x)) for k,x in sorted(numres[v].items())))
