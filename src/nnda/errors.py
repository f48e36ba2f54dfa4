"""Exceptions raised at nnda's boundaries. Each message says what was wrong and where."""


class NndaError(Exception):
    """Base class of every error nnda raises on bad input."""


class ConfigError(NndaError, ValueError):
    """A configuration (scenario, study, tracker) failed validation."""


class DatasetError(NndaError, ValueError):
    """A dataset on disk is missing, corrupt, of another format version or schema."""


class ModelError(NndaError, ValueError):
    """A model file is missing, corrupt or of another format or feature version, or a model got bad input."""


class FilterError(NndaError, ValueError):
    """A filter got bad input (shape, non-finite value, invalid covariance) or lost positive definiteness."""


class TrackingError(NndaError, ValueError):
    """A tracker got a bad scan (time not increasing, non-finite contact, wrong shape) or config."""
