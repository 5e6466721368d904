"""The model file parsed once per process (:func:`osim_model.model_xml`): the tree ElementTree's own file
parser gives, and a new parse whenever the file's bytes change."""
import xml.etree.ElementTree as ET
from pathlib import Path

from ocp_constraints.biomech.osim_model import model_xml

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"


def test_the_cached_tree_is_the_file_parsers_tree(tmp_path):
    path = tmp_path / "m.osim"
    path.write_text('<?xml version="1.0" encoding="UTF-8"?>\n<OpenSimDocument Version="40000"><Model name="m">'
                    '<BodySet><objects><Body name="b\u00e9"><mass>2.5</mass></Body></objects></BodySet>'
                    '</Model></OpenSimDocument>', encoding="utf-8")
    first = model_xml(path)
    assert ET.tostring(first) == ET.tostring(ET.parse(path).getroot())
    assert model_xml(path) is first                 # read again: the same parse


def test_an_edited_model_file_is_parsed_again(tmp_path):
    path = tmp_path / "m.osim"
    path.write_text('<OpenSimDocument Version="40000"><Model name="a"/></OpenSimDocument>')
    assert model_xml(path).find("Model").get("name") == "a"
    path.write_text('<OpenSimDocument Version="40000"><Model name="b"/></OpenSimDocument>')
    assert model_xml(path).find("Model").get("name") == "b"


def test_the_jw_model_parses_as_elementtree_parses_it():
    path = SHARED / "grand-challenge-knee-jw" / "reducepoly_model" / "JW_All_Body_Model-scaled_forvisualization_leftright_v42.osim"
    if not path.exists():
        import pytest

        pytest.skip(f"{path} not here")
    assert ET.tostring(model_xml(path)) == ET.tostring(ET.parse(path).getroot())
