"""The understanding benchmark's wordings: its kinds, sets and domains, the templates of each set
and the words that sound like an object's name (:mod:`siftom.bench.understanding`).

The templates are benchmark data only: nothing in the product reads them.
"""

from __future__ import annotations

KINDS = ("plain", "misheard", "correction", "negation", "context", "compound", "count", "any_object",
         "absent", "nonrequest")
SETS = ("dev", "heldout", "unseen")
KITCHEN = "kitchen-v0"
HOUSEHOLD = "household-table-v0"
DOMAINS = (KITCHEN, HOUSEHOLD)
# domains whose objects are asked for in numbers ("three forks"); a kitchen object is one item
COUNTED = (HOUSEHOLD,)
WORLD_SEEDS = {"dev": 201, "heldout": 202, "unseen": 203}
DEFAULT_WORLDS = 6  # per domain
PER_KIND = 2  # items per kind and world
NUMBER_WORDS = {2: "two", 3: "three", 4: "four"}
MAX_COUNT = 4

# -- templates -----------------------------------------------------------------------------------
# {x}, {y}: a noun phrase with its determiner ("the cereal", "the forks", "three forks");
# {x_be}, {y_be}: "is" or "are" for them. Kinds ``negation`` and ``nonrequest`` take {x} or nothing.

TEMPLATES: dict[str, dict[str, tuple[str, ...]]] = {
    "dev": {
        "plain": (
            "could you pass me {x}",
            "{x} please",
            "can you bring me {x}",
            "I need {x}",
            "please get {x}",
            "hey robot, grab {x} for me",
        ),
        "misheard": (
            "can you hand me {x}",
            "pass {x}, please",
            "I'd like {x}",
            "would you fetch {x}",
        ),
        "correction": (
            "no, not {x}, {y}",
            "can you hand me {x}, um, I mean {y}",
            "not {x}, {y} please",
            "bring me {x}, sorry, {y}",
            "get me {x}, no wait, I meant {y}",
        ),
        "negation": (
            "don't bring {x}",
            "I don't need {x}",
            "please don't get {x}",
            "we don't need {x} anymore",
            "you don't have to fetch {x}",
        ),
        "context": (
            "pass me {x} for {y}",
            "can you get me {x}, {y} {y_be} already here",
            "grab {x} from next to {y}",
            "I need {x} to go with {y}",
            "{x} please, I already have {y}",
        ),
        "compound": (
            "could you get me {x} and {y}",
            "bring me {x} and {y}",
            "{x} and {y}, please",
            "I need {x} and {y}",
        ),
        "count": (
            "bring me {x}",
            "could you get {x}",
            "I need {x} on the table",
            "{x}, please",
        ),
        "any_object": (
            "could you grab me {x}",
            "can I have {x}",
            "please bring {x} over here",
            "get me {x}, would you",
        ),
        "absent": (
            "bring me {x}",
            "could you pass me {x}",
            "I need {x} now",
            "can you fetch {x}",
        ),
        "nonrequest": (
            "thank you",
            "thanks, that's all",
            "the weather is nice today",
            "my phone battery is dead",
            "where did I leave my keys",
            "what time is it",
            "I saw {x} on sale at the store yesterday",
            "did you hear what happened at work today",
        ),
    },
    "heldout": {
        "plain": (
            "would you mind handing me {x}",
            "I could use {x} over here",
            "{x}, when you get a chance",
            "fetch {x} for me, would you",
            "go and get {x}",
            "robot, I want {x}",
        ),
        "misheard": (
            "could I get {x} please",
            "bring {x} here",
            "I'm looking for {x}",
            "any chance you could grab {x}",
        ),
        "correction": (
            "fetch {x}, actually, make that {y}",
            "{x}, no sorry, {y}",
            "bring me {y} instead of {x}",
            "I meant {y}, not {x}",
            "hand me {x}, scratch that, {y}",
        ),
        "negation": (
            "just leave {x} alone",
            "there's no need to bring {x}",
            "please don't touch {x}",
            "forget about {x}",
            "skip {x} for now",
        ),
        "context": (
            "I've got {y} already, just get me {x}",
            "to go with {y}, could you fetch {x}",
            "{y} {y_be} ready, now I need {x}",
            "fetch {x} from beside {y}",
            "for {y}, I'll need {x}",
        ),
        "compound": (
            "I'll need {x} as well as {y}",
            "grab {x}, and also {y}",
            "{x} plus {y}, please",
            "I want {x} and {y} over here",
        ),
        "count": (
            "could I have {x}",
            "{x} on the table, please",
            "set out {x}",
            "go get {x}",
        ),
        "any_object": (
            "would you bring {x} over",
            "I'd love {x} right now",
            "fetch me {x} please",
            "{x}, if you don't mind",
        ),
        "absent": (
            "would you hand me {x}",
            "go fetch {x}",
            "I'm after {x}",
            "could I get {x} from you",
        ),
        "nonrequest": (
            "cheers, that's everything",
            "I think it might rain later",
            "did anyone feed the cat",
            "that was a great movie last night",
            "hmm, who called me earlier",
            "I really should water the plants",
            "{x} {x_be} so expensive these days",
            "my sister is visiting next week",
        ),
    },
    # Written fresh, apart from both sets above, as people talk to a home robot: contractions,
    # fillers, politeness, indirect requests and clauses in either order.
    "unseen": {
        "plain": (
            "Be a dear and grab {x} for me.",
            "Um, can I get {x} when you're free?",
            "Hey, would you mind bringing over {x}?",
            "I could really use {x} right now.",
            "When you get a sec, pass me {x}, would you?",
            "Uh, {x} over here, if you could.",
            "Do you think you could fetch {x}?",
            "I'm gonna need {x} over here.",
        ),
        "misheard": (
            "Mind handing me {x} real quick?",
            "Um, I'd like {x}, if that's okay.",
            "Would you mind bringing {x} my way?",
            "Go ahead and grab {x}, thanks.",
            "Uh, could I trouble you for {x}?",
            "Think you could rustle up {x} for me?",
        ),
        "correction": (
            "I'm after {x}, oh, hang on, I mean {y}.",
            "Go grab {x}... hmm, on second thought, make it {y}.",
            "I need {x}, um, no, I meant {y}.",
            "Can you pass {x}? Scratch that, {y} instead.",
            "Uh, {x}, no wait, {y}, please.",
            "Hand me {x}. Hmm, actually, I'd rather have {y}.",
            "Would you get {x}, er, I mean {y}?",
        ),
        "negation": (
            "Don't worry about {x}, we're fine.",
            "Nah, forget about {x}, I changed my mind.",
            "Please don't grab {x}, I'm all set.",
            "We won't be needing {x} tonight.",
            "You can leave {x} alone, thanks.",
            "Um, skip {x}, I don't want any.",
            "Turns out I won't need {x} after all.",
        ),
        "context": (
            "Okay, {y} {y_be} out already, so I just need {x}.",
            "I've already got {y}, I just need {x} now.",
            "Right, I've sorted out {y}; what I still need is {x}.",
            "Seeing as {y} {y_be} here already, could you just round up {x}?",
            "Don't bother with {y}, I've got that covered. Just {x}, please.",
            "Could you bring {x} over by {y}?",
            "Now that I've got {y}, can you find me {x}?",
        ),
        "compound": (
            "Could you round up {x} and {y} for me, please?",
            "Um, I'll need {x}, and also {y}.",
            "Grab {x} for me, oh, and {y} as well.",
            "Can I get {x} plus {y}?",
            "I need {x} and, uh, {y} too, if you don't mind.",
            "Would you pass {x}? And {y} while you're at it.",
            "When you've got a second, I'm gonna need {x} and {y} over here.",
        ),
        "count": (
            "We've got guests, so um, could you set out {x}?",
            "I'll need {x} for everyone.",
            "Can you grab {x} from over there?",
            "Um, can we get {x} set out at our places?",
            "Mind grabbing {x}? We've got company.",
            "Bring over {x} when you can.",
            "It's not just me tonight, so {x}, please.",
        ),
        "any_object": (
            "Oh, while you're up, could you get me {x}?",
            "I know it's random, but can you bring {x}?",
            "Oh, before I forget, I'd like you to bring {x}.",
            "Okay, this is gonna sound odd, but I'd like {x}, please.",
            "Could you run and get {x}? Thanks a bunch.",
            "Pop over and get {x} for me, would you?",
        ),
        "absent": (
            "Do me a favor and dig out {x}, would you?",
            "Um, is there any way you could pass me {x}?",
            "Hey there, would you track down {x} for me?",
            "Would you get {x} for me?",
            "I'd love {x}, if it's not too much trouble.",
            "Go grab {x}, would you?",
        ),
        "nonrequest": (
            "Thanks, that's everything for now.",
            "Wow, it smells amazing in here.",
            "Hey Sam, did you remember to call your mom back?",
            "I already put {x} away, don't worry.",
            "Oh, I love how this room looks with the lights down.",
            "Jamie, are you done with {x}?",
            "Great job, that's exactly what I wanted.",
            "Huh, I didn't know we still had {x}.",
        ),
    },
}

# Words that sound like an object's name but are not a name of it: class -> ((singular, plural),
# ...). The dev set uses the first, the held-out set the second (a class with one is dev only),
# the unseen set the second or, for a class with one, the first.
# A confusion is used only where it names no object of the world (tomato -> potato only where
# there is no potato).
CONFUSIONS: dict[str, tuple[tuple[str, str], ...]] = {
    # kitchen
    "cereal": (("serial", "serials"), ("surreal", "surreals")),
    "flour": (("flower", "flowers"), ("floor", "floors")),
    "milk": (("silk", "silks"), ("mill", "mills")),
    "tea": (("tee", "tees"), ("key", "keys")),
    "coffee": (("toffee", "toffees"),),
    "honey": (("money", "money"), ("funny", "funny")),
    "butter": (("batter", "batters"), ("gutter", "gutters")),
    "pepper": (("paper", "papers"),),
    "salt": (("malt", "malts"), ("fault", "faults")),
    "rice": (("price", "prices"), ("dice", "dice")),
    "bread": (("bred", "bred"), ("thread", "threads")),
    "bacon": (("baking", "baking"), ("beacon", "beacons")),
    "cheese": (("cheeks", "cheeks"), ("chess", "chess")),
    "pasta": (("pastor", "pastors"), ("pastel", "pastels")),
    "egg": (("leg", "legs"), ("peg", "pegs")),
    "onion": (("union", "unions"), ("bunion", "bunions")),
    "carrot": (("parrot", "parrots"), ("carat", "carats")),
    "banana": (("bandana", "bandanas"), ("bonanza", "bonanzas")),
    "lettuce": (("let us", "let us"), ("lattice", "lattices")),
    "yogurt": (("yoga", "yoga"),),
    "chicken": (("thicken", "thicken"), ("checking", "checking")),
    "garlic": (("gaelic", "gaelic"),),
    "apple": (("ample", "ample"), ("chapel", "chapels")),
    "dressing": (("pressing", "pressings"),),
    "ham": (("hem", "hems"), ("hum", "hums")),
    "beans": (("beads", "beads"), ("jeans", "jeans")),
    "tomato": (("potato", "potatoes"),),
    # both
    "cup": (("cap", "caps"), ("pup", "pups")),
    "bowl": (("ball", "balls"), ("goal", "goals")),
    "plate": (("plane", "planes"), ("slate", "slates")),
    # household
    "fork": (("fort", "forts"), ("folk", "folks")),
    "knife": (("life", "lives"), ("knight", "knights")),
    "spoon": (("moon", "moons"), ("spool", "spools")),
    "mug": (("bug", "bugs"), ("hug", "hugs")),
    "wineglass": (("wine grass", "wine grasses"), ("wine class", "wine classes")),
    "waterglass": (("water grass", "water grasses"), ("water class", "water classes")),
}
