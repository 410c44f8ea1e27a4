"""Streams share a pool of recognisers per vocabulary, one per CPU of the admission budget: the
utterances of a burst decode side by side, each heard as the one recogniser would hear it."""

from __future__ import annotations

import threading

from siftom.scenarios.base import get_scenario
from siftom.service.runtime import Runtime, ServiceSettings
from siftom.speech.tts import synthesize


def test_a_burst_decodes_on_as_many_recognisers_as_cpus_with_the_same_words(tmp_path):
    rt = Runtime(ServiceSettings(), tmp_path, owns_dir=False)
    rt.admission.budget = 2
    try:
        sc = get_scenario("kitchen-cereal-v0")
        hear = rt.stream_recogniser(sc.world, sc.verb, 3)
        x = synthesize("can you pass me the cereal")
        heard = [hear(x) for _ in range(2)]  # the pool hands out its recognisers in turn
        assert heard[0].text == heard[1].text and heard[0].text
        assert [h.text for h in heard[0].instruction.nbest] == [h.text for h in heard[1].instruction.nbest]
        pool = rt._pool(sc.world, sc.verb)
        recs = [pool.get() for _ in range(2)]
        assert recs[0] is not recs[1] and recs[0].engine is not recs[1].engine
        assert rt.observer.recogniser(sc.world, sc.verb) in recs  # the observer's own is one of them
        for r in recs:
            pool.put(r)
        # two utterances at once: both recognisers busy together, and both counted in the queue
        seen: list[int] = []
        gate = threading.Barrier(2)

        def one() -> None:
            gate.wait()
            hear(x)
            seen.append(rt.admission.stats()["recognising"])

        threads = [threading.Thread(target=one) for _ in range(2)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        assert rt.admission.stats()["recognising"] == 0 and len(seen) == 2
        assert rt.stream_recogniser(sc.world, sc.verb, 3)(x).text == heard[0].text  # the same pool again
    finally:
        rt.close()
