import pytest

from fogbank.settings import SettingsError, get_settings


def test_bad_setting_names_key_and_value(monkeypatch):
    get_settings.cache_clear()
    monkeypatch.setenv("FOGBANK_PORT", "99999")
    with pytest.raises(SettingsError) as exc:
        get_settings()
    assert "FOGBANK_PORT=99999" in str(exc.value).replace("'", "")
    monkeypatch.delenv("FOGBANK_PORT")
    get_settings.cache_clear()
    assert get_settings().port == 8000
