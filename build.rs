//! Reads `modelDescription.xml` (the single source of truth for the FMU's variables; the
//! environment variable AEM_MODEL_DESCRIPTION may name a copy with other start values), checks
//! it, and generates `$OUT_DIR/model_description.rs`: the GUID, the model identifier, the
//! capability flags, one enum variant per variable of each type with its value reference,
//! causality and start value, the enumeration types with their named items, and the log
//! categories. Enumeration variables are set and got as Integers (FMI 2.0 section 2.1.7), so
//! they are variants of `IntegerVariable` that also name their enumeration type. The FMI layer matches exhaustively on that enum,
//! so a variable added to or removed from the XML without code is a build error.

use std::collections::{BTreeMap, HashSet};
use std::fmt::Write as _;
use std::path::PathBuf;

const MODEL_IDENTIFIER: &str = "AemElectrolyser";

fn main() {
    let manifest = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").expect("CARGO_MANIFEST_DIR"));
    // AEM_MODEL_DESCRIPTION: another model description to build from (packaging/package.py
    // --parameters builds the FMU binary from a copy whose start values are identified ones,
    // so that the binary's defaults and the shipped model description agree).
    println!("cargo:rerun-if-env-changed=AEM_MODEL_DESCRIPTION");
    let xml_path = match std::env::var_os("AEM_MODEL_DESCRIPTION") {
        Some(path) if !path.is_empty() => PathBuf::from(path),
        _ => manifest.join("modelDescription.xml"),
    };
    println!("cargo:rerun-if-changed={}", xml_path.display());
    println!("cargo:rerun-if-changed=build.rs");
    let text = std::fs::read_to_string(&xml_path)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", xml_path.display()));
    let generated = match generate(&text) {
        Ok(code) => code,
        Err(msg) => panic!("modelDescription.xml: {msg}"),
    };
    let out =
        PathBuf::from(std::env::var("OUT_DIR").expect("OUT_DIR")).join("model_description.rs");
    std::fs::write(&out, generated)
        .unwrap_or_else(|e| panic!("cannot write {}: {e}", out.display()));
}

/// The FMI types implemented, with the Rust type of their values.
#[derive(Clone, Copy, PartialEq)]
enum Type {
    Real,
    Integer,
    Boolean,
    String,
}

impl Type {
    fn element(self) -> &'static str {
        match self {
            Type::Real => "Real",
            Type::Integer => "Integer",
            Type::Boolean => "Boolean",
            Type::String => "String",
        }
    }
    fn rust(self) -> &'static str {
        match self {
            Type::Real => "f64",
            Type::Integer => "i32",
            Type::Boolean => "bool",
            Type::String => "&'static str",
        }
    }
}

/// One named item of an enumeration type (`<SimpleType><Enumeration><Item>`).
struct Item {
    name: String,
    value: i32,
    description: String,
}

/// An enumeration type of `<TypeDefinitions>`.
struct Enumeration {
    name: String,
    description: String,
    items: Vec<Item>,
}

struct Variable {
    name: String,
    vr: u32,
    ty: Type,
    /// The enumeration type of an `<Enumeration>` variable (an Integer to FMI's functions).
    enumeration: Option<String>,
    causality: String,
    /// The unit: the Real's unit attribute; Integer and Boolean variables (which FMI 2.0 gives
    /// no unit attribute) state theirs in the description as "[unit]"; enumerations have none.
    unit: String,
    /// Start value as Rust source (`Some(..)`), or None.
    start: Option<String>,
}

fn generate(text: &str) -> Result<String, String> {
    let doc = roxmltree::Document::parse(text).map_err(|e| format!("not well-formed XML: {e}"))?;
    let root = doc.root_element();
    if root.tag_name().name() != "fmiModelDescription"
        || root.attribute("fmiVersion") != Some("2.0")
    {
        return Err("root must be <fmiModelDescription fmiVersion=\"2.0\">".into());
    }
    let guid = root.attribute("guid").ok_or("guid is missing")?;
    let child = |name: &str| root.children().find(|n| n.has_tag_name(name));
    let cs = child("CoSimulation").ok_or("no <CoSimulation> element")?;
    if cs.attribute("modelIdentifier") != Some(MODEL_IDENTIFIER) {
        return Err(format!(
            "CoSimulation modelIdentifier must be {MODEL_IDENTIFIER}"
        ));
    }
    if child("ModelExchange").is_some() {
        return Err("this FMU implements co-simulation only; remove <ModelExchange>".into());
    }
    let flag = |name: &str| cs.attribute(name) == Some("true");

    let units: HashSet<&str> = child("UnitDefinitions")
        .map(|u| {
            u.children()
                .filter(|n| n.has_tag_name("Unit"))
                .filter_map(|n| n.attribute("name"))
                .collect()
        })
        .unwrap_or_default();
    let categories: Vec<&str> = child("LogCategories")
        .map(|c| {
            c.children()
                .filter(|n| n.has_tag_name("Category"))
                .filter_map(|n| n.attribute("name"))
                .collect()
        })
        .unwrap_or_default();

    let enumerations = enumerations(child("TypeDefinitions"))?;

    let mut variables = Vec::new();
    let mut seen_vr = HashSet::new();
    let mut seen_name = HashSet::new();
    let vars = child("ModelVariables").ok_or("no <ModelVariables>")?;
    for sv in vars.children().filter(|n| n.has_tag_name("ScalarVariable")) {
        let name = sv
            .attribute("name")
            .ok_or("a ScalarVariable has no name")?
            .to_string();
        let vr: u32 = sv
            .attribute("valueReference")
            .and_then(|v| v.parse().ok())
            .ok_or(format!(
                "{name}: valueReference missing or not an unsigned integer"
            ))?;
        let element = sv
            .children()
            .find(|n| n.is_element())
            .ok_or(format!("{name}: no type element"))?;
        let enumeration = if element.has_tag_name("Enumeration") {
            let declared = element
                .attribute("declaredType")
                .ok_or(format!("{name}: an Enumeration needs a declaredType"))?;
            if !enumerations.iter().any(|e| e.name == declared) {
                return Err(format!(
                    "{name}: declaredType {declared} is not an enumeration of <TypeDefinitions>"
                ));
            }
            Some(declared.to_string())
        } else {
            None
        };
        let ty = [Type::Real, Type::Integer, Type::Boolean, Type::String]
            .into_iter()
            .find(|t| element.has_tag_name(t.element()) || (enumeration.is_some() && *t == Type::Integer))
            .ok_or(format!("{name}: only Real, Integer, Enumeration, Boolean and String variables are implemented"))?;
        let unit = match ty {
            Type::Integer if enumeration.is_some() => String::new(),
            Type::Real => {
                let unit = element
                    .attribute("unit")
                    .ok_or(format!("{name}: every Real variable must declare a unit"))?;
                if !units.contains(unit) {
                    return Err(format!("{name}: unit {unit} is not in <UnitDefinitions>"));
                }
                unit.to_string()
            }
            Type::Integer | Type::Boolean | Type::String => {
                let description = sv.attribute("description").unwrap_or("");
                let unit = description
                    .rfind('[')
                    .and_then(|a| description[a + 1..].find(']').map(|b| &description[a + 1..a + 1 + b]))
                    .ok_or(format!("{name}: an {} variable states its unit at the end of its description, as [1]", ty.element()))?;
                unit.to_string()
            }
        };
        let start = match element.attribute("start") {
            None => None,
            Some(s) => Some(match ty {
                Type::Real => format!(
                    "{:?}",
                    s.parse::<f64>()
                        .map_err(|_| format!("{name}: start {s} is not a number"))?
                ),
                Type::Integer => s
                    .parse::<i32>()
                    .map_err(|_| format!("{name}: start {s} is not a 32-bit integer"))?
                    .to_string(),
                Type::Boolean => match s {
                    "true" | "1" => "true".into(),
                    "false" | "0" => "false".into(),
                    _ => return Err(format!("{name}: start {s} is not a Boolean")),
                },
                Type::String => format!("{s:?}"),
            }),
        };
        if let (Some(declared), Some(start)) = (&enumeration, &start) {
            let items = &enumerations
                .iter()
                .find(|e| &e.name == declared)
                .expect("checked above")
                .items;
            if !items.iter().any(|item| item.value.to_string() == *start) {
                return Err(format!(
                    "{name}: start {start} is not an item of {declared}"
                ));
            }
        }
        if ty == Type::Integer {
            for bound in ["min", "max"] {
                if let Some(b) = element.attribute(bound) {
                    b.parse::<i32>()
                        .map_err(|_| format!("{name}: {bound} {b} is not a 32-bit integer"))?;
                }
            }
        }
        let causality = sv.attribute("causality").unwrap_or("local").to_string();
        let variability = sv
            .attribute("variability")
            .unwrap_or("continuous")
            .to_string();
        match causality.as_str() {
            "input" | "parameter" if start.is_none() => {
                return Err(format!("{name}: {causality} needs a start value"))
            }
            "output" if start.is_some() => {
                return Err(format!("{name}: calculated output must not have a start"))
            }
            "input" | "parameter" | "output" => {}
            other => return Err(format!("{name}: causality {other} is not implemented")),
        }
        if causality == "parameter" && variability != "fixed" {
            return Err(format!(
                "{name}: parameters are fixed (tunable parameters are not implemented)"
            ));
        }
        // Value references are unique per type in FMI 2.0; here they are unique overall.
        if !seen_vr.insert(vr) {
            return Err(format!("{name}: valueReference {vr} is used twice"));
        }
        if !seen_name.insert(name.clone()) {
            return Err(format!("{name}: name used twice"));
        }
        variables.push(Variable {
            name,
            vr,
            ty,
            enumeration,
            causality,
            unit,
            start,
        });
    }

    // ModelStructure: Outputs must list exactly the outputs, in order, by 1-based index.
    let structure = child("ModelStructure").ok_or("no <ModelStructure>")?;
    let outputs: Vec<usize> = variables
        .iter()
        .enumerate()
        .filter(|(_, v)| v.causality == "output")
        .map(|(i, _)| i + 1)
        .collect();
    let listed = |section: &str| -> Vec<usize> {
        structure
            .children()
            .find(|n| n.has_tag_name(section))
            .map(|s| {
                s.children()
                    .filter(|n| n.has_tag_name("Unknown"))
                    .filter_map(|n| n.attribute("index").and_then(|i| i.parse().ok()))
                    .collect()
            })
            .unwrap_or_default()
    };
    if listed("Outputs") != outputs {
        return Err(format!("<Outputs> must list indices {outputs:?}"));
    }
    if listed("InitialUnknowns") != outputs {
        return Err(format!("<InitialUnknowns> must list indices {outputs:?}"));
    }
    for unknown in structure
        .descendants()
        .filter(|n| n.has_tag_name("Unknown"))
    {
        for dep in unknown
            .attribute("dependencies")
            .unwrap_or("")
            .split_whitespace()
        {
            let idx: usize = dep
                .parse()
                .map_err(|_| format!("dependency {dep} is not an index"))?;
            let v = variables
                .get(idx.wrapping_sub(1))
                .ok_or(format!("dependency index {idx} out of range"))?;
            if v.causality == "output" {
                return Err(format!(
                    "dependency {idx} ({}) must be an input or parameter",
                    v.name
                ));
            }
        }
    }

    let mut code = String::new();
    let w = &mut code;
    writeln!(
        w,
        "// Generated by build.rs from modelDescription.xml. Do not edit."
    )
    .unwrap();
    writeln!(
        w,
        "/// GUID of the model description; fmi2Instantiate checks it."
    )
    .unwrap();
    writeln!(w, "pub const GUID: &str = {guid:?};").unwrap();
    writeln!(w, "/// Model identifier: the binary's name inside the FMU.").unwrap();
    writeln!(
        w,
        "pub const MODEL_IDENTIFIER: &str = {MODEL_IDENTIFIER:?};"
    )
    .unwrap();
    for (konst, attr) in [
        (
            "CAN_HANDLE_VARIABLE_COMMUNICATION_STEP_SIZE",
            "canHandleVariableCommunicationStepSize",
        ),
        ("CAN_INTERPOLATE_INPUTS", "canInterpolateInputs"),
        ("CAN_GET_AND_SET_FMU_STATE", "canGetAndSetFMUstate"),
        ("CAN_SERIALIZE_FMU_STATE", "canSerializeFMUstate"),
        (
            "PROVIDES_DIRECTIONAL_DERIVATIVE",
            "providesDirectionalDerivative",
        ),
        ("CAN_RUN_ASYNCHRONOUSLY", "canRunAsynchronuously"),
    ] {
        writeln!(w, "/// `{attr}` of the model description.").unwrap();
        writeln!(w, "pub const {konst}: bool = {};", flag(attr)).unwrap();
    }
    writeln!(w, "/// Log categories declared in the model description.").unwrap();
    writeln!(w, "pub const LOG_CATEGORIES: &[&str] = &{categories:?};").unwrap();

    enumeration_code(w, &enumerations);
    writeln!(w, "/// Causality of a variable.").unwrap();
    writeln!(w, "#[derive(Clone, Copy, Debug, PartialEq, Eq)]").unwrap();
    writeln!(w, "pub enum Causality {{ Input, Output, Parameter }}").unwrap();
    for ty in [Type::Real, Type::Integer, Type::Boolean, Type::String] {
        let of_type: Vec<&Variable> = variables.iter().filter(|v| v.ty == ty).collect();
        variable_enum(w, ty, &of_type);
    }
    writeln!(
        w,
        "/// Start values of inputs and parameters, by SCREAMING_SNAKE name."
    )
    .unwrap();
    writeln!(w, "pub mod start {{").unwrap();
    let starts: BTreeMap<String, (&str, &str)> = variables
        .iter()
        .filter_map(|v| {
            v.start
                .as_deref()
                .map(|s| (screaming(&v.name), (v.ty.rust(), s)))
        })
        .collect();
    for (name, (ty, value)) in starts {
        // A const's reference is 'static already.
        let ty = ty.replace("&'static ", "&");
        writeln!(
            w,
            "    #[allow(missing_docs)] pub const {name}: {ty} = {value};"
        )
        .unwrap();
    }
    writeln!(w, "}}").unwrap();
    Ok(code)
}

/// The enumeration types of `<TypeDefinitions>`: each `<SimpleType>` must be an
/// `<Enumeration>` with at least one item; item names and values are unique within a type.
fn enumerations(definitions: Option<roxmltree::Node>) -> Result<Vec<Enumeration>, String> {
    let Some(definitions) = definitions else {
        return Ok(Vec::new());
    };
    let mut out: Vec<Enumeration> = Vec::new();
    for simple in definitions
        .children()
        .filter(|n| n.has_tag_name("SimpleType"))
    {
        let name = simple
            .attribute("name")
            .ok_or("a SimpleType has no name")?
            .to_string();
        if out.iter().any(|e| e.name == name) {
            return Err(format!("SimpleType {name} is declared twice"));
        }
        let enumeration = simple
            .children()
            .find(|n| n.has_tag_name("Enumeration"))
            .ok_or(format!(
                "SimpleType {name}: only Enumeration types are implemented"
            ))?;
        let mut items: Vec<Item> = Vec::new();
        for item in enumeration.children().filter(|n| n.has_tag_name("Item")) {
            let item_name = item
                .attribute("name")
                .ok_or(format!("{name}: an Item has no name"))?
                .to_string();
            let value = item
                .attribute("value")
                .and_then(|v| v.parse::<i32>().ok())
                .ok_or(format!(
                    "{name}.{item_name}: value missing or not a 32-bit integer"
                ))?;
            if items
                .iter()
                .any(|i| i.name == item_name || i.value == value)
            {
                return Err(format!(
                    "{name}.{item_name}: name or value {value} used twice"
                ));
            }
            items.push(Item {
                name: item_name,
                value,
                description: item.attribute("description").unwrap_or("").to_string(),
            });
        }
        if items.is_empty() {
            return Err(format!(
                "SimpleType {name}: an Enumeration needs at least one Item"
            ));
        }
        out.push(Enumeration {
            name,
            description: simple.attribute("description").unwrap_or("").to_string(),
            items,
        });
    }
    Ok(out)
}

/// `Enumeration`, `EnumerationItem` and one constant per enumeration type, by SCREAMING_SNAKE
/// name: the items with their values and descriptions, in model-description order.
fn enumeration_code(w: &mut String, enumerations: &[Enumeration]) {
    writeln!(w, "/// One named item of an enumeration type.").unwrap();
    writeln!(w, "#[derive(Clone, Copy, Debug, PartialEq, Eq)]").unwrap();
    writeln!(w, "pub struct EnumerationItem {{ pub name: &'static str, pub value: i32, pub description: &'static str }}").unwrap();
    writeln!(w, "/// An enumeration type of `<TypeDefinitions>`.").unwrap();
    writeln!(w, "#[derive(Clone, Copy, Debug, PartialEq, Eq)]").unwrap();
    writeln!(w, "pub struct Enumeration {{ pub name: &'static str, pub description: &'static str, pub items: &'static [EnumerationItem] }}").unwrap();
    writeln!(w, "impl Enumeration {{").unwrap();
    writeln!(w, "    /// The item with this value.").unwrap();
    writeln!(w, "    pub fn item(&self, value: i32) -> Option<&'static EnumerationItem> {{ self.items.iter().find(|i| i.value == value) }}").unwrap();
    writeln!(w, "}}").unwrap();
    writeln!(w, "/// The enumeration types, by SCREAMING_SNAKE name.").unwrap();
    writeln!(w, "pub mod enumeration {{").unwrap();
    writeln!(w, "    use super::{{Enumeration, EnumerationItem}};").unwrap();
    for e in enumerations {
        writeln!(w, "    /// `{}`: {}.", e.name, e.description).unwrap();
        writeln!(w, "    pub const {}: Enumeration = Enumeration {{ name: {:?}, description: {:?}, items: &[", screaming(&e.name), e.name, e.description).unwrap();
        for i in &e.items {
            writeln!(
                w,
                "        EnumerationItem {{ name: {:?}, value: {}, description: {:?} }},",
                i.name, i.value, i.description
            )
            .unwrap();
        }
        writeln!(w, "    ] }};").unwrap();
    }
    writeln!(w, "}}").unwrap();
}

/// `RealVariable`, `IntegerVariable` or `BooleanVariable`: one variant per variable of that
/// type, with its value reference, name, unit, causality and start value.
fn variable_enum(w: &mut String, ty: Type, variables: &[&Variable]) {
    let en = format!("{}Variable", ty.element());
    let rust = ty.rust();
    writeln!(
        w,
        "/// Every {} variable of the model description.",
        ty.element()
    )
    .unwrap();
    writeln!(w, "#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]").unwrap();
    writeln!(w, "pub enum {en} {{").unwrap();
    for v in variables {
        match &v.enumeration {
            Some(e) => writeln!(
                w,
                "    /// `{}` (enumeration {e}), value reference {}.",
                v.name, v.vr
            )
            .unwrap(),
            None => writeln!(
                w,
                "    /// `{}` [{}], value reference {}.",
                v.name, v.unit, v.vr
            )
            .unwrap(),
        }
        writeln!(w, "    {},", pascal(&v.name)).unwrap();
    }
    writeln!(w, "}}").unwrap();
    writeln!(w, "impl {en} {{").unwrap();
    writeln!(
        w,
        "    /// All {} variables in model-description order.",
        ty.element()
    )
    .unwrap();
    let all: Vec<String> = variables
        .iter()
        .map(|v| format!("{en}::{}", pascal(&v.name)))
        .collect();
    writeln!(
        w,
        "    pub const ALL: [{en}; {}] = [{}];",
        all.len(),
        all.join(", ")
    )
    .unwrap();
    writeln!(w, "    /// The variable with this value reference.").unwrap();
    writeln!(
        w,
        "    pub const fn from_value_reference(vr: u32) -> Option<Self> {{ match vr {{"
    )
    .unwrap();
    for v in variables {
        writeln!(w, "        {} => Some({en}::{}),", v.vr, pascal(&v.name)).unwrap();
    }
    writeln!(w, "        _ => None, }} }}").unwrap();
    let accessor = |w: &mut String, fname: &str, ret: &str, f: &dyn Fn(&Variable) -> String| {
        if variables.is_empty() {
            writeln!(
                w,
                "    pub const fn {fname}(self) -> {ret} {{ match self {{}} }}"
            )
            .unwrap();
            return;
        }
        writeln!(
            w,
            "    pub const fn {fname}(self) -> {ret} {{ match self {{"
        )
        .unwrap();
        for v in variables {
            writeln!(w, "        {en}::{} => {},", pascal(&v.name), f(v)).unwrap();
        }
        writeln!(w, "    }} }}").unwrap();
    };
    writeln!(w, "    /// Value reference.").unwrap();
    accessor(w, "value_reference", "u32", &|v| v.vr.to_string());
    writeln!(w, "    /// Name in the model description.").unwrap();
    accessor(w, "name", "&'static str", &|v| format!("{:?}", v.name));
    writeln!(w, "    /// Unit in the model description.").unwrap();
    accessor(w, "unit", "&'static str", &|v| format!("{:?}", v.unit));
    if ty == Type::Integer {
        writeln!(
            w,
            "    /// The enumeration type of an Enumeration variable (None: a plain Integer)."
        )
        .unwrap();
        accessor(
            w,
            "enumeration",
            "Option<Enumeration>",
            &|v| match &v.enumeration {
                Some(e) => format!("Some(enumeration::{})", screaming(e)),
                None => "None".into(),
            },
        );
    }
    writeln!(w, "    /// Causality.").unwrap();
    accessor(w, "causality", "Causality", &|v| {
        format!("Causality::{}", pascal(&v.causality))
    });
    writeln!(w, "    /// Start value (inputs and parameters).").unwrap();
    accessor(
        w,
        "start",
        &format!("Option<{rust}>"),
        &|v| match &v.start {
            Some(s) => format!("Some({s})"),
            None => "None".into(),
        },
    );
    writeln!(w, "}}").unwrap();
}

fn pascal(name: &str) -> String {
    let mut chars = name.chars();
    match chars.next() {
        Some(c) => c.to_ascii_uppercase().to_string() + chars.as_str(),
        None => String::new(),
    }
}

fn screaming(name: &str) -> String {
    let mut out = String::new();
    for (i, c) in name.chars().enumerate() {
        if c.is_ascii_uppercase() && i > 0 {
            out.push('_');
        }
        out.push(c.to_ascii_uppercase());
    }
    out
}
