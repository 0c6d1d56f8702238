"""Every polishpath error survives a trip through pickle (issue 29: errors come back from worker processes).

An error raised inside a case of ``simulate``'s process pool or on a Dask worker reaches the command line
pickled. Exception's default pickling calls ``cls(*args)`` with the joined message, which raises
TypeError for an error whose constructor takes other arguments (MissingDependencyError): the user saw a
pickling traceback instead of the install hint.
"""

from __future__ import annotations

import inspect
import pickle

import pytest

import polishpath.errors as errors


def _error_classes():
    return sorted((c for _, c in inspect.getmembers(errors, inspect.isclass)
                   if issubclass(c, errors.PolishPathError) and c.__module__ == errors.__name__),
                  key=lambda c: c.__name__)


def _make(cls):
    if cls is errors.MissingDependencyError:
        return cls("dask", "a cluster comparison", extra="dask")
    return cls("the spacing is 0 mm", "Give --spacing > 0.")


@pytest.mark.parametrize("cls", _error_classes(), ids=lambda c: c.__name__)
def test_error_round_trips_through_pickle_with_its_message_hint_and_type(cls):
    err = _make(cls)
    err.extra_field = 42  # attributes a raiser adds (a count, a path) come back too
    back = pickle.loads(pickle.dumps(err))
    assert type(back) is cls
    assert str(back) == str(err)
    assert back.message == err.message and back.hint == err.hint
    assert back.exit_code == err.exit_code == 2
    assert back.extra_field == 42


def test_missing_dependency_error_keeps_its_install_hint_after_pickling():
    back = pickle.loads(pickle.dumps(errors.MissingDependencyError("dask", "a cluster comparison", "dask")))
    assert "pip install 'polishpath[dask]'" in str(back)
    assert isinstance(back, ImportError)
