"""Tabular learners (Q-learning, SARSA, Expected SARSA, user-defined) trained on the task.

    from tableclean_suite.learners import train
    result = train(learner="q_learning", reward="r4", runs=1000, iterations=3000)
"""

from tableclean_suite.learners.rules import (  # noqa: F401
    EXPECTED_SARSA,
    Q_LEARNING,
    SARSA,
    TabularLearner,
    get_learner,
    learner_names,
    register_learner,
)
from tableclean_suite.learners.kernel import code_digest  # noqa: F401
from tableclean_suite.learners.train import (  # noqa: F401
    BACKENDS,
    TrainingResult,
    available_backends,
    train,
    validate_hyperparameters,
)
from tableclean_suite.learners.transitions import CorruptTableError, TransitionTable  # noqa: F401
