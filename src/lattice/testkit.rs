//! Domains built in Rust for the lattice, oracle and lint tests (no front end needed).

use crate::ir::*;

/// Entities a test concept adds: (name, kind, region, attribute overrides).
pub type Adds<'a> = &'a [(&'a str, KindId, &'a str, &'a [(&'a str, Value)])];

/// Builds a [`Domain`] declaration by declaration; every declaration gets its own span
/// (`start` = declaration number × 10) so tests can check where a diagnostic points.
pub struct Dom {
    pub d: Domain,
    next_span: u32,
}

pub fn num(x: f64) -> Value {
    Value::Number(x)
}

pub fn range(lo: f64, hi: f64) -> Value {
    Value::Range(lo, hi)
}

/// A filter on kinds and tags.
pub fn filter(kinds: &[KindId], tags: &[TagId]) -> TargetFilter {
    TargetFilter { kinds: kinds.to_vec(), tags: tags.to_vec(), world: false }
}

pub fn world_filter() -> TargetFilter {
    TargetFilter { world: true, ..TargetFilter::default() }
}

impl Dom {
    pub fn new(selection: Selection) -> Dom {
        let d = Domain { selection, ..crate::ir::testkit::domain(&[]) };
        let mut dom = Dom { d, next_span: 1 };
        dom.region("lane");
        dom.region("sidewalk");
        dom
    }

    pub fn span(&mut self) -> Span {
        let s = Span { file: 0, start: self.next_span * 10, end: self.next_span * 10 + 5 };
        self.next_span += 1;
        s
    }

    pub fn region(&mut self, name: &str) -> RegionId {
        let span = self.span();
        self.d.regions.push(Region {
            name: name.into(),
            doc: String::new(),
            x: (0.0, 60.0),
            y: (-1.0, 1.0),
            z: (0.0, 0.0),
            scenic: None,
            span,
        });
        RegionId(self.d.regions.len() as u32 - 1)
    }

    pub fn tag(&mut self, name: &str) -> TagId {
        let span = self.span();
        self.d.tags.push(TagDef { name: name.into(), doc: String::new(), span });
        TagId(self.d.tags.len() as u32 - 1)
    }

    /// A kind with numeric (length) or boolean attributes and their defaults.
    pub fn kind(&mut self, name: &str, tags: &[TagId], attrs: &[(&str, Value)]) -> KindId {
        let attrs = attrs
            .iter()
            .map(|(n, v)| {
                let ty = match v {
                    Value::Bool(_) => AttrType::Bool,
                    _ => AttrType::Number { dimension: "length".into(), min: 0.0, max: 120.0 },
                };
                AttrDef { name: (*n).into(), ty, default: v.clone(), doc: String::new(), span: Span::default() }
            })
            .collect();
        let span = self.span();
        self.d.kinds.push(Kind {
            name: name.into(),
            doc: String::new(),
            tags: tags.to_vec(),
            attrs,
            shape: vec![],
            regions: vec![],
            span,
        });
        KindId(self.d.kinds.len() as u32 - 1)
    }

    /// A world attribute of a plain number type.
    pub fn world(&mut self, name: &str, default: Value) {
        self.d.world.push(AttrDef {
            name: name.into(),
            ty: AttrType::Number { dimension: String::new(), min: 0.0, max: 100.0 },
            default,
            doc: String::new(),
            span: Span::default(),
        });
    }

    fn push_concept(
        &mut self,
        name: &str,
        kind: ConceptKind,
        effects: Vec<Effect>,
        target: Option<TargetFilter>,
    ) -> ConceptId {
        let id = ConceptId(self.d.concepts.len() as u32);
        let span = self.span();
        self.d.concepts.push(Concept {
            name: name.into(),
            id,
            kind,
            description: format!("the {name} concept"),
            category: String::new(),
            probe: Probe::default(),
            effects,
            target,
            render: RenderBindings::default(),
            span,
        });
        id
    }

    /// A concept adding entities `(name, kind, region, attribute overrides)` ahead of ego.
    pub fn concept(&mut self, name: &str, adds: Adds) -> ConceptId {
        let effects = adds
            .iter()
            .map(|(n, k, region, attrs)| Effect::Add {
                name: (*n).into(),
                kind: *k,
                region: self.d.region_by_name(region).expect("test region"),
                relation: Relation { name: "ahead_of".into(), to: None },
                attrs: attrs.iter().map(|(a, v)| ((*a).into(), v.clone())).collect(),
                span: Span::default(),
            })
            .collect();
        self.push_concept(name, ConceptKind::Concept, effects, None)
    }

    /// A concept that sets a world attribute.
    pub fn world_concept(&mut self, name: &str, attr: &str, value: Value) -> ConceptId {
        let effects = vec![Effect::SetWorld { attr: attr.into(), value, span: Span::default() }];
        self.push_concept(name, ConceptKind::Concept, effects, None)
    }

    /// A modifier setting attributes of its target (or the world for a world filter).
    pub fn modifier(&mut self, name: &str, target: TargetFilter, sets: &[(&str, Value)]) -> ConceptId {
        let world = target.world && target.kinds.is_empty() && target.tags.is_empty();
        let effects = sets
            .iter()
            .map(|(a, v)| {
                if world {
                    Effect::SetWorld { attr: (*a).into(), value: v.clone(), span: Span::default() }
                } else {
                    Effect::SetTarget { attr: (*a).into(), value: v.clone(), span: Span::default() }
                }
            })
            .collect();
        self.push_concept(name, ConceptKind::Modifier, effects, Some(target))
    }

    /// A modifier moving its target to another region.
    pub fn mover(&mut self, name: &str, target: TargetFilter, region: &str) -> ConceptId {
        let region = self.d.region_by_name(region).expect("test region");
        self.push_concept(
            name,
            ConceptKind::Modifier,
            vec![Effect::MoveTarget { region, span: Span::default() }],
            Some(target),
        )
    }

    pub fn constraint(&mut self, name: &str, rule: ConstraintRule) {
        let span = self.span();
        self.d.constraints.push(Constraint { name: name.into(), doc: String::new(), rule, span });
    }

    pub fn exclusive(&mut self, name: &str, members: &[ConceptId]) {
        self.constraint(
            name,
            ConstraintRule::AtMost { members: ConceptSet::from_ids(members.iter().copied()), max: 1 },
        );
    }

    pub fn question(&mut self, name: &str, options: &[&str]) -> QuestionId {
        let span = self.span();
        let options = options.iter().map(|o| AnswerOption { name: (*o).into(), text: format!("answer {o}") }).collect();
        self.d.questions.push(Question { name: name.into(), text: format!("question {name}?"), options, span });
        QuestionId(self.d.questions.len() as u32 - 1)
    }

    pub fn rule(
        &mut self,
        name: &str,
        question: QuestionId,
        expect: u32,
        when: Option<Expr>,
        elements: &[ConceptId],
    ) -> RuleId {
        let id = RuleId(self.d.rules.len() as u32);
        let span = self.span();
        self.d.rules.push(Rule {
            name: name.into(),
            id,
            rationale: format!("because of {name}"),
            question,
            expect,
            when,
            elements: ConceptSet::from_ids(elements.iter().copied()),
            safe: false,
            span,
        });
        id
    }

    /// Mark the last rule as a safe-scene rule.
    pub fn safe(&mut self) {
        if let Some(r) = self.d.rules.last_mut() {
            r.safe = true;
        }
    }

    pub fn build(self) -> Domain {
        self.d
    }
}

/// `exists e: FILTER where e in REGION and e.ATTR <op> VALUE` style conditions.
pub fn exists(filter: TargetFilter, cond: Option<Expr>) -> Expr {
    Expr::Exists { var: "e".into(), filter, cond: cond.map(Box::new) }
}

pub fn in_region(d: &Domain, region: &str) -> Expr {
    Expr::InRegion { var: "e".into(), region: d.region_by_name(region).expect("test region") }
}

pub fn attr_cmp(attr: &str, op: CmpOp, value: Value) -> Expr {
    Expr::Cmp { var: Some("e".into()), attr: attr.into(), op, value }
}

/// A small driving domain in the shape of the paper's (appendix C), 30 concepts: towns,
/// intersection and lights, near/far obstacles, agents, props, location/distance modifiers and
/// weathers, with the paper's priority rules (near obstacle in lane → stop, red light → stop,
/// anything in the lane → slow, else go).
pub fn driving() -> Domain {
    let mut b = Dom::new(Selection::Priority);
    b.world("town", num(1.0));
    b.world("intersection", num(0.0));
    b.world("light", num(0.0));
    b.world("weather", num(0.0));
    let collidable = b.tag("Collidable");
    let obstacle = b.kind("Obstacle", &[collidable], &[("distance", range(6.0, 12.0))]);
    let agent = b.kind("Agent", &[collidable], &[("distance", range(6.0, 12.0))]);
    let prop = b.kind("Prop", &[collidable], &[("distance", range(6.0, 12.0))]);
    let t1 = b.world_concept("town_town01", "town", num(1.0));
    let t2 = b.world_concept("town_town02", "town", num(2.0));
    let inter = b.world_concept("intersection_ego", "intersection", num(1.0));
    let red = b.world_concept("light_red", "light", num(1.0));
    let green = b.world_concept("light_green", "light", num(2.0));
    for name in ["chain_barrier", "debris", "obstruction"] {
        b.concept(&format!("{name}_near"), &[(name, obstacle, "lane", &[("distance", range(2.0, 4.0))])]);
        b.concept(&format!("{name}_far"), &[(name, obstacle, "lane", &[("distance", range(15.0, 25.0))])]);
    }
    for name in ["pedestrian", "child_pedestrian", "wheelchair_pedestrian", "police_pedestrian", "cyclist"] {
        b.concept(name, &[(name, agent, "lane", &[])]);
    }
    b.concept("emergency_vehicle", &[("emergency_vehicle", agent, "lane", &[("distance", range(8.0, 20.0))])]);
    for name in ["cone", "bus_stop", "garbage_bin"] {
        b.concept(name, &[(name, prop, "lane", &[])]);
    }
    let sidewalk = b.mover("on_sidewalk", filter(&[], &[collidable]), "sidewalk");
    let lane = b.mover("on_lane", filter(&[], &[collidable]), "lane");
    let near = b.modifier("near", filter(&[], &[collidable]), &[("distance", range(2.0, 4.0))]);
    let far = b.modifier("far", filter(&[], &[collidable]), &[("distance", range(15.0, 25.0))]);
    let weathers: Vec<ConceptId> = ["clear_noon", "hard_rain", "soft_rain", "foggy", "wet", "cloudy"]
        .iter()
        .enumerate()
        .map(|(i, w)| b.world_concept(&format!("weather_{w}"), "weather", num(i as f64)))
        .collect();
    b.exclusive("one_town", &[t1, t2]);
    b.exclusive("one_light", &[red, green]);
    b.exclusive("near_xor_far", &[near, far]);
    b.exclusive("sidewalk_xor_lane", &[sidewalk, lane]);
    b.exclusive("one_weather", &weathers);
    let any_light = ConceptSet::from_ids([red, green]);
    for l in any_light.iter() {
        b.constraint(
            "light_needs_intersection",
            ConstraintRule::Requires { concept: l, any_of: ConceptSet::single(inter) },
        );
    }
    let q = b.question("drive", &["stop", "slow", "go"]);
    let d = b.d.clone();
    let coll = filter(&[], &[collidable]);
    let near_in_lane = Expr::And(vec![in_region(&d, "lane"), attr_cmp("distance", CmpOp::Le, num(4.0))]);
    b.rule("near_in_lane", q, 0, Some(exists(coll.clone(), Some(near_in_lane))), &[]);
    b.rule("red_light", q, 0, Some(Expr::Has(red)), &[]);
    b.rule("hazard_ahead", q, 1, Some(exists(coll, Some(in_region(&d, "lane")))), &[]);
    b.rule("clear", q, 2, None, &[]);
    b.build()
}

/// `n` independent concepts (no constraints: every set is valid), each setting a world
/// attribute, and two priority rules (`c0` → option `b`, else `a`): the shape of `revelio bench
/// scale`'s generated domains, for tests of what grows with the number of concepts.
pub fn independent(n: usize) -> Domain {
    let mut b = Dom::new(Selection::Priority);
    b.world("on", num(0.0));
    let ids: Vec<ConceptId> = (0..n).map(|i| b.world_concept(&format!("c{i}"), "on", num(1.0))).collect();
    let q = b.question("q", &["a", "b"]);
    if let Some(&first) = ids.first() {
        b.rule("first", q, 1, Some(Expr::Has(first)), &[]);
    }
    b.rule("rest", q, 0, None, &[]);
    b.build()
}
