import pytest

from tdicam import cosim


@pytest.fixture(params=cosim.SIMULATORS)
def sim(request):
    return request.param
