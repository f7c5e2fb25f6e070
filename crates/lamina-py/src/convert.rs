//! Python values to TOML values, so that a scene or leaf given as a dict goes through the
//! same parameter dictionary, checks and messages as a file. Errors name the key path.

use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};

/// `obj` as a TOML value; `key` is its dotted path for errors (`film.width`,
/// `material[1].pigments.cab`). Accepted: bool, int, float, str, list, tuple, dict with
/// str keys, and NumPy arrays and scalars (through their `tolist()`).
pub fn to_toml(obj: &Bound<'_, PyAny>, key: &str) -> Result<toml::Value, String> {
    if obj.is_instance_of::<PyBool>() {
        return Ok(toml::Value::Boolean(
            obj.extract::<bool>().map_err(|e| e.to_string())?,
        ));
    }
    if obj.is_instance_of::<PyInt>() {
        return obj
            .extract::<i64>()
            .map(toml::Value::Integer)
            .map_err(|_| format!("{key}: the integer {obj} is too large"));
    }
    if obj.is_instance_of::<PyFloat>() {
        return Ok(toml::Value::Float(
            obj.extract::<f64>().map_err(|e| e.to_string())?,
        ));
    }
    if obj.is_instance_of::<PyString>() {
        return Ok(toml::Value::String(
            obj.extract::<String>().map_err(|e| e.to_string())?,
        ));
    }
    if let Ok(d) = obj.cast::<PyDict>() {
        let mut t = toml::Table::new();
        for (k, v) in d.iter() {
            let name: String = k.extract().map_err(|_| {
                format!(
                    "{key}: the key {} is not a string",
                    k.repr().map_or_else(|_| "?".into(), |r| r.to_string())
                )
            })?;
            let sub = if key.is_empty() {
                name.clone()
            } else {
                format!("{key}.{name}")
            };
            t.insert(name, to_toml(&v, &sub)?);
        }
        return Ok(toml::Value::Table(t));
    }
    let items: Option<Vec<Bound<'_, PyAny>>> = if let Ok(l) = obj.cast::<PyList>() {
        Some(l.iter().collect())
    } else if let Ok(t) = obj.cast::<PyTuple>() {
        Some(t.iter().collect())
    } else {
        None
    };
    if let Some(items) = items {
        return items
            .iter()
            .enumerate()
            .map(|(i, v)| to_toml(v, &format!("{key}[{i}]")))
            .collect::<Result<Vec<_>, _>>()
            .map(toml::Value::Array);
    }
    if obj.is_none() {
        return Err(format!(
            "{key}: None has no value in a scene; leave the key out for its default"
        ));
    }
    // NumPy arrays and scalars (and anything else that lists itself).
    if obj.hasattr("dtype").unwrap_or(false) && obj.hasattr("tolist").unwrap_or(false) {
        let plain = obj
            .call_method0("tolist")
            .map_err(|e| format!("{key}: {e}"))?;
        return to_toml(&plain, key);
    }
    let kind = obj
        .get_type()
        .name()
        .map_or_else(|_| "?".to_string(), |n| n.to_string());
    Err(format!(
        "{key}: a {kind} cannot be a scene value (use numbers, strings, booleans, lists and dicts)"
    ))
}

/// A Python mapping at the top of a scene or leaf as a TOML table (its text is what the
/// loader reads).
pub fn dict_to_table(d: &Bound<'_, PyAny>, what: &str) -> Result<toml::Table, String> {
    match to_toml(d, "")? {
        toml::Value::Table(t) => Ok(t),
        _ => Err(format!("{what} must be a dict")),
    }
}

/// A TOML value as a Python object (tables as dicts, arrays as lists).
pub fn to_python<'py>(py: Python<'py>, v: &toml::Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match v {
        toml::Value::String(s) => s.into_pyobject(py)?.into_any(),
        toml::Value::Integer(i) => i.into_pyobject(py)?.into_any(),
        toml::Value::Float(f) => f.into_pyobject(py)?.into_any(),
        toml::Value::Boolean(b) => b.into_pyobject(py)?.to_owned().into_any(),
        toml::Value::Datetime(d) => d.to_string().into_pyobject(py)?.into_any(),
        toml::Value::Array(a) => {
            let l = PyList::empty(py);
            for x in a {
                l.append(to_python(py, x)?)?;
            }
            l.into_any()
        }
        toml::Value::Table(t) => {
            let d = PyDict::new(py);
            for (k, x) in t {
                d.set_item(k, to_python(py, x)?)?;
            }
            d.into_any()
        }
    })
}
