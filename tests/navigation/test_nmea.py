"""NMEA 0183 sentences: checksums against published and hand-computed examples, fields as autopilots read them."""

import pytest

from seamodem.navigation.nmea import checksum, format_lat, format_lon, gga, rmc, sentence

#: the NMEA 0183 examples everyone quotes (e.g. the gpsd and NMEA reference pages), with their checksums
KNOWN = [
    ("GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,", "47"),
    ("GPRMC,123519,A,4807.038,N,01131.000,E,022.4,084.4,230394,003.1,W", "6A"),
]


@pytest.mark.parametrize("body, expected", KNOWN)
def test_checksum_of_published_sentences(body, expected):
    assert checksum(body) == expected
    assert sentence(body) == f"${body}*{expected}\r\n"


def test_checksum_by_hand():
    # 'A' = 0x41; 'A' ^ 'B' = 0x41 ^ 0x42 = 0x03; "GPGGA": 0x47^0x50 = 0x17, ^0x47 = 0x50, ^0x47 = 0x17, ^0x41 = 0x56
    assert checksum("A") == "41" and checksum("AB") == "03" and checksum("GPGGA") == "56"
    assert checksum("") == "00"


def _xor(text):  # independent of the module: the definition, character by character
    value = 0
    for ch in text:
        value ^= ord(ch)
    return value


def test_gga_fields_reproduce_the_published_position():
    # 48°07.038' N, 11°31.000' E at 12:35:19 UTC: the published example's position
    s = gga(time_s=12 * 3600 + 35 * 60 + 19, lat_deg=48 + 7.038 / 60, lon_deg=11 + 31.0 / 60, sigma_m=0.9,
            altitude_m=-5.0)
    assert s.endswith("\r\n") and s.startswith("$")
    body, cs = s[1:-2].split("*")
    assert int(cs, 16) == _xor(body)
    f = body.split(",")
    assert f[:10] == ["GPGGA", "123519.00", "4807.038000", "N", "01131.000000", "E", "1", "12", "0.9", "-5.00"]
    assert len(f) == 15  # GGA has 14 fields after the type


def test_rmc_fields_south_west_knots_course_date():
    t = 764422519.0  # 1994-03-23 11:35:19 UTC
    s = rmc(time_s=t, lat_deg=-(48 + 7.038 / 60), lon_deg=-(11 + 31.0 / 60), speed_mps=1852 / 3600 * 22.4,
            course_deg=-275.6)
    body, cs = s[1:-2].split("*")
    assert int(cs, 16) == _xor(body)
    f = body.split(",")
    assert f == ["GPRMC", "113519.00", "A", "4807.038000", "S", "01131.000000", "W", "22.40", "84.4", "230394", "", "",
                 "A"]


def test_coordinates_round_into_the_next_degree_and_refuse_out_of_range():
    assert format_lat(10.99999999999) == ("1100.000000", "N")
    assert format_lon(-0.5) == ("00030.000000", "W")
    with pytest.raises(ValueError, match="latitude must be in"):
        format_lat(91.0)
    with pytest.raises(ValueError, match="longitude must be in"):
        format_lon(float("nan"))


def test_the_sentences_shown_in_docs_live_carry_their_checksums():
    from pathlib import Path

    page = (Path(__file__).resolve().parents[2] / "docs" / "live.md").read_text(encoding="utf-8")
    shown = [line for line in page.splitlines() if line.startswith("$GP")]
    assert len(shown) == 2
    for line in shown:
        body, cs = line[1:].split("*")
        assert checksum(body) == cs
