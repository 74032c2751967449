//! A small driving-like domain built in Rust, for the sampler's and emitters' unit tests.

use crate::ir::*;

pub(crate) fn part(prim: Primitive, size: [f64; 3], at: [f64; 3], when: Option<Expr>) -> ShapePart {
    ShapePart {
        prim,
        size,
        at,
        color: [0.5, 0.5, 0.5, 1.0],
        yaw_deg: 0.0,
        roll_deg: 0.0,
        pitch_deg: 0.0,
        material: "matte".into(),
        when,
        shadow: true,
    }
}

fn attr(name: &str, ty: AttrType, default: Value) -> AttrDef {
    AttrDef { name: name.into(), ty, default, doc: String::new(), span: Span::default() }
}

fn length(name: &str, min: f64, max: f64, default: Value) -> AttrDef {
    attr(name, AttrType::Number { dimension: "length".into(), min, max }, default)
}

fn region(name: &str, x: (f64, f64), y: (f64, f64), scenic: Option<&str>) -> Region {
    Region {
        name: name.into(),
        doc: String::new(),
        x,
        y,
        z: (0.0, 0.0),
        scenic: scenic.map(Into::into),
        span: Span::default(),
    }
}

fn concept(name: &str, kind: ConceptKind, effects: Vec<Effect>, target: Option<TargetFilter>) -> Concept {
    Concept {
        name: name.into(),
        id: ConceptId(0),
        kind,
        description: format!("The {name} concept."),
        category: String::new(),
        probe: Probe::default(),
        effects,
        target,
        render: RenderBindings::default(),
        span: Span::default(),
    }
}

fn add(name: &str, kind: u32, region: u32, attrs: Vec<(&str, Value)>) -> Effect {
    Effect::Add {
        name: name.into(),
        kind: KindId(kind),
        region: RegionId(region),
        relation: Relation { name: "ahead_of".into(), to: None },
        attrs: attrs.into_iter().map(|(a, v)| (a.into(), v)).collect(),
        span: Span::default(),
    }
}

fn self_cmp(attr: &str, value: Value) -> Option<Expr> {
    Some(Expr::Cmp { var: Some("self".into()), attr: attr.into(), op: CmpOp::Eq, value })
}

fn world_is(attr: &str, value: Value) -> Option<Expr> {
    Some(Expr::Cmp { var: None, attr: attr.into(), op: CmpOp::Eq, value })
}

/// Kinds: 0 Pedestrian, 1 Container, 2 Tree (an `Extra`). Regions: 0 lane, 1 sidewalk,
/// 2 verge. Concepts: 0 pedestrian, 1 obstruction_near, 2 town_town02, 3 weather_hard_rain,
/// 4 near (modifier), 5 on_sidewalk (modifier), 6 holding_sign (modifier).
pub(crate) fn tiny_domain() -> Domain {
    let town = EnumId(0);
    let weather = EnumId(1);
    let positional = |default_distance| {
        vec![length("distance", 0.0, 120.0, default_distance), length("lateral", -8.0, 8.0, Value::Number(0.0))]
    };
    let mut ped_attrs = positional(Value::Range(6.0, 12.0));
    ped_attrs.push(attr("holding_sign", AttrType::Bool, Value::Bool(false)));
    let kind = |name: &str, tags: Vec<u32>, attrs, shape| Kind {
        name: name.into(),
        doc: String::new(),
        tags: tags.into_iter().map(TagId).collect(),
        attrs,
        shape,
        regions: vec![],
        span: Span::default(),
    };
    let mut concepts = vec![
        concept("pedestrian", ConceptKind::Concept, vec![add("ped", 0, 0, vec![])], None),
        concept(
            "obstruction_near",
            ConceptKind::Concept,
            vec![add("box", 1, 0, vec![("distance", Value::Range(2.0, 4.0))])],
            None,
        ),
        concept(
            "town_town02",
            ConceptKind::Concept,
            vec![Effect::SetWorld { attr: "town".into(), value: Value::Enum(town, 1), span: Span::default() }],
            None,
        ),
        concept(
            "weather_hard_rain",
            ConceptKind::Concept,
            vec![Effect::SetWorld { attr: "weather".into(), value: Value::Enum(weather, 1), span: Span::default() }],
            None,
        ),
        concept(
            "near",
            ConceptKind::Modifier,
            vec![Effect::SetTarget { attr: "distance".into(), value: Value::Range(2.0, 4.0), span: Span::default() }],
            Some(TargetFilter { kinds: vec![], tags: vec![TagId(0)], world: false }),
        ),
        concept(
            "on_sidewalk",
            ConceptKind::Modifier,
            vec![Effect::MoveTarget { region: RegionId(1), span: Span::default() }],
            Some(TargetFilter { kinds: vec![], tags: vec![TagId(0)], world: false }),
        ),
        concept(
            "holding_sign",
            ConceptKind::Modifier,
            vec![Effect::SetTarget { attr: "holding_sign".into(), value: Value::Bool(true), span: Span::default() }],
            Some(TargetFilter { kinds: vec![KindId(0)], tags: vec![], world: false }),
        ),
    ];
    let bindings = [
        ("{id} = new Pedestrian {region}, with blueprint 'walker.pedestrian.0001'", "A pedestrian stands ahead."),
        ("{id} = new Prop {region}, with blueprint 'static.prop.container'", "A large container blocks the lane."),
        ("", "The street is in a compact town."),
        ("", "Heavy rain falls."),
        ("", "It is only a few meters away."),
        ("", "It is on the sidewalk."),
        ("", "The person holds a red sign."),
    ];
    for (i, (c, (scenic, prompt))) in concepts.iter_mut().zip(bindings).enumerate() {
        c.id = ConceptId(i as u32);
        c.render.scenic = (!scenic.is_empty()).then(|| scenic.to_owned());
        c.render.prompt = Some(prompt.to_owned());
    }
    let text = "domain tiny\n// a fixture built in Rust\n";
    Domain {
        name: "tiny".into(),
        files: vec![SourceFile { name: "tiny.rev".into(), text: text.into() }],
        units: vec![],
        relations: vec![RelationDef {
            name: "ahead_of".into(),
            text: "is ahead of".into(),
            placement: Placement { ahead: Some((0.0, 1000.0)), ..Placement::default() },
            span: Span::default(),
        }],
        enums: vec![
            EnumDef { name: "Town".into(), variants: vec!["town01".into(), "town02".into()], span: Span::default() },
            EnumDef {
                name: "Weather".into(),
                variants: vec!["clear_noon".into(), "hard_rain".into()],
                span: Span::default(),
            },
        ],
        tags: ["Collidable", "Agent", "Extra"]
            .into_iter()
            .map(|n| TagDef { name: n.into(), doc: String::new(), span: Span::default() })
            .collect(),
        kinds: vec![
            kind(
                "Pedestrian",
                vec![0, 1],
                ped_attrs,
                vec![
                    part(Primitive::Capsule, [0.45, 0.45, 1.2], [0.0, 0.0, 1.0], None),
                    part(Primitive::Box, [0.1, 0.6, 0.5], [0.0, 0.0, 2.0], self_cmp("holding_sign", Value::Bool(true))),
                ],
            ),
            kind(
                "Container",
                vec![0],
                positional(Value::Range(6.0, 12.0)),
                vec![part(Primitive::Box, [2.4, 2.4, 2.6], [0.0, 0.0, 1.3], None)],
            ),
            kind("Tree", vec![2], vec![], vec![part(Primitive::Cylinder, [0.6, 0.6, 4.0], [0.0, 0.0, 2.0], None)]),
        ],
        world: vec![
            attr("town", AttrType::Enum(town), Value::Enum(town, 0)),
            attr("weather", AttrType::Enum(weather), Value::Enum(weather, 0)),
            attr("intersection", AttrType::Bool, Value::Bool(false)),
            attr("sun", AttrType::Number { dimension: "angle".into(), min: 0.0, max: 90.0 }, Value::Range(40.0, 70.0)),
        ],
        regions: vec![
            region(
                "lane",
                (0.0, 60.0),
                (-1.5, 1.5),
                Some(
                    "ahead of (new OrientedPoint at ((front of ego) offset along ego.heading by ({right}, {distance})), facing ego.heading), with regionContainedIn road",
                ),
            ),
            region(
                "sidewalk",
                (0.0, 60.0),
                (-4.0, -3.2),
                Some(
                    "ahead of (new OrientedPoint at ((front of ego) offset along ego.heading by ({right}, {distance})), facing ego.heading), with regionContainedIn None",
                ),
            ),
            region("verge", (5.0, 60.0), (-12.0, -9.0), None),
        ],
        presets: vec![Preset {
            name: "hard_rain".into(),
            doc: String::new(),
            for_variant: Some((weather, 1)),
            params: vec![
                ("cloudiness".into(), 90.0),
                ("precipitation".into(), 90.0),
                ("wetness".into(), 80.0),
                ("puddle_shine".into(), 0.7),
            ],
            span: Span::default(),
        }],
        stage: vec![
            StageItem {
                name: "road".into(),
                parts: vec![part(Primitive::Plane, [120.0, 8.0, 0.0], [60.0, 0.0, 0.0], None)],
                at: [0.0; 3],
                repeat: None,
                when: None,
                span: Span::default(),
            },
            StageItem {
                name: "houses".into(),
                parts: vec![part(Primitive::Box, [9.0, 7.0, 5.0], [0.0, 0.0, 2.5], None)],
                at: [12.0, 11.0, 0.0],
                repeat: Some((3, [16.0, 0.0, 0.0])),
                when: world_is("town", Value::Enum(town, 0)),
                span: Span::default(),
            },
        ],
        concepts,
        constraints: vec![],
        questions: vec![],
        selection: Selection::Priority,
        rules: vec![],
        camera: Camera::default(),
        allow: vec![],
        visibility: Default::default(),
    }
}

/// A set of the tiny domain by concept names.
pub(crate) fn set(d: &Domain, names: &[&str]) -> ConceptSet {
    d.parse_set(names).expect("fixture concept names")
}

/// The real driving domain (`domains/driving.rev`).
pub(crate) fn driving() -> Domain {
    crate::check::compile_source("domains/driving.rev", include_str!("../../domains/driving.rev"))
        .unwrap_or_else(|d| panic!("domains/driving.rev does not compile: {d:?}"))
}
