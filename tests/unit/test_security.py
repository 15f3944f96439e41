"""Per-client keys (service/security.py client_key): what the per-client caps count by."""

from __future__ import annotations

import pytest

from fogbank.service.security import client_key

pytestmark = pytest.mark.unit


def test_an_ipv6_client_is_its_64_and_an_ipv4_one_its_address():
    """A host given a /64 may use any of its 2^64 addresses: the caps count the /64. An
    IPv4 address, and one mapped into IPv6, count as themselves; a name (the test
    client's) as it is."""
    assert client_key("2001:db8:1:2::1") == client_key("2001:db8:1:2:ffff:ffff:ffff:fffe") == "2001:db8:1:2::/64"
    assert client_key("2001:db8:1:3::1") == "2001:db8:1:3::/64"
    assert client_key("2001:DB8:1:2::abc") == "2001:db8:1:2::/64"
    assert client_key("::1") == "::/64"
    assert client_key("203.0.113.7") == "203.0.113.7"
    assert client_key("203.0.113.8") == "203.0.113.8"
    assert client_key("::ffff:203.0.113.7") == "203.0.113.7"
    assert client_key("testclient") == "testclient"
