"""The paper's imitation side, in torch and never Ray: the 19 input planes (`features`), the
CNN (`network`), behaviour cloning (`bc`), learned policies as agents (`learned`) and
how fast the networks learn on this CPU (`speed`)."""
