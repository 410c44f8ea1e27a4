"""People: the dataset format people's recordings are stored in, recording participants,
annotating stimuli and rating the robot.

Both the pages that serve people (:mod:`siftom.service`: ``siftom collect``, ``siftom annotate``,
the ratings API) and the benchmark (:mod:`siftom.bench`: building, evaluating and scoring) use
these modules; they import neither.

* :mod:`siftom.people.stimuli`: stimuli and datasets (docs/dataset-format.md).
* :mod:`siftom.people.collect`: a dataset folder that fills up as participants speak.
* :mod:`siftom.people.annotate`: the human baseline's plan, annotators and answers.
* :mod:`siftom.people.ratings`: people's ratings of the robot after a trial.
"""
