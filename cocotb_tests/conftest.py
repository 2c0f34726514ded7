import pytest

from tdicam import cosim


@pytest.fixture(params=cosim.SIMULATORS)
def sim(request):
    return request.param


def pytest_collection_modifyitems(items):
    # cocotb test modules (stream_tb) are not pytest tests
    pass
