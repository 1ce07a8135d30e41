"""Tabular learners trained on the task: Q-learning, SARSA, Expected SARSA, double Q-learning,
Watkins's Q(lambda), SARSA(lambda), Dyna-Q and user-defined ones, with any exploration.

    from tableclean_suite.learners import train
    result = train(learner="q_learning", reward="r4", runs=1000, iterations=3000)
    result = train("q_lambda", learner_options={"lambda_": 0.8}, exploration="softmax", q_init=0.5)
"""

from tableclean_suite.learners.rules import (  # noqa: F401
    DOUBLE_Q_LEARNING,
    DYNA_Q,
    EXPECTED_SARSA,
    Q_LAMBDA,
    Q_LEARNING,
    SARSA,
    SARSA_LAMBDA,
    TabularLearner,
    get_learner,
    learner_names,
    register_learner,
)
from tableclean_suite.learners.exploration import (  # noqa: F401
    EpsilonGreedy,
    Exploration,
    ExponentialDecay,
    LinearDecay,
    Softmax,
    VisitDecay,
    as_exploration,
    exploration_names,
    parse_exploration,
    softmax_probabilities,
)
from tableclean_suite.learners.kernel import code_digest  # noqa: F401
from tableclean_suite.learners.train import (  # noqa: F401
    LearnerSettings,
    RunOptions,
    TrainingResult,
    train,
    validate_hyperparameters,
)
from tableclean_suite.learners.transitions import CorruptTableError, TransitionTable  # noqa: F401
