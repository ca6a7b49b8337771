"""Tables and figures from results (frames, never a database): the look (palette), number formats,
labels, the HTML/Markdown document, and the generic figures the report engine and the problems'
sections draw."""
